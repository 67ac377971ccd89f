// monomeshd's wiring: RunDaemon (the configuration's checks, the Daemon), the start-up and the
// main loop. The loop hands each event to its concern's file (app/daemon_loop.h lists them).
#include "app/daemon.h"

#include <signal.h>
#include <spdlog/spdlog.h>
#include <sys/epoll.h>
#include <sys/eventfd.h>
#include <sys/signalfd.h>
#include <sys/stat.h>
#include <sys/timerfd.h>
#include <systemd/sd-daemon.h>

#include <cerrno>
#include <chrono>
#include <cstring>
#include <exception>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "app/control.h"
#include "app/daemon_loop.h"
#include "app/event_fd.h"
#include "calib/calib_io.h"
#include "capture/source_uri.h"

namespace mm {
namespace daemon_detail {

int Daemon::Start() {
  int leftovers = 0;
  bool spool_path_unusable = false;
  if (std::string error = spool_.Recover(&leftovers, &spool_path_unusable); !error.empty()) {
    spdlog::critical("{}", error);
    return spool_path_unusable ? kExitConfig : kExitUnavailable;
  }
  if (leftovers > 0) {
    spdlog::warn("spool {}: removed {} incomplete entries left by an earlier crash",
                 spool_.dir().string(), leftovers);
  }

  epoll_.reset(::epoll_create1(EPOLL_CLOEXEC));
  frame_event_.reset(::eventfd(0, EFD_NONBLOCK | EFD_CLOEXEC));
  done_event_.reset(::eventfd(0, EFD_NONBLOCK | EFD_CLOEXEC));
  gate_event_.reset(::eventfd(0, EFD_NONBLOCK | EFD_CLOEXEC));
  walk_event_.reset(::eventfd(0, EFD_NONBLOCK | EFD_CLOEXEC));
  sigset_t signals;
  sigemptyset(&signals);
  for (int s : {SIGTERM, SIGINT, SIGHUP, SIGCHLD}) sigaddset(&signals, s);  // SIGCHLD: hooks.
  // Block before any thread starts, so every thread inherits the mask and signalfd sees them
  // (SIGUSR1 likewise, through its SignalTrigger).
  pthread_sigmask(SIG_BLOCK, &signals, nullptr);
  triggers_.push_back(std::make_unique<SignalTrigger>(SIGUSR1));
  if (std::string error = triggers_.back()->Open(); !error.empty()) {
    spdlog::critical("trigger: {}", error);
    return kExitUnavailable;
  }
  ::signal(SIGPIPE, SIG_IGN);
  signal_fd_.reset(::signalfd(-1, &signals, SFD_NONBLOCK | SFD_CLOEXEC));
  timer_fd_.reset(::timerfd_create(CLOCK_MONOTONIC, TFD_NONBLOCK | TFD_CLOEXEC));
  const itimerspec period{{0, 100'000'000}, {0, 100'000'000}};
  ::timerfd_settime(timer_fd_.get(), 0, &period, nullptr);
  for (int fd : {frame_event_.get(), done_event_.get(), gate_event_.get(), walk_event_.get(),
                 signal_fd_.get(), timer_fd_.get()}) {
    AddFd(fd);
  }

  try {
    capture_ = std::make_unique<CaptureThread>(
        CreateFrameSource(config_.camera_uri, config_.config_dir.string()),
        CaptureThread::Callbacks{
            .on_frame = [fd = frame_event_.get()] { SignalEventFd(fd); },
            .on_error = [](const std::string& e) { spdlog::error("camera: {}", e); }});
  } catch (const SourceUriError& e) {
    spdlog::critical("{}", e.what());
    return kExitConfig;  // The URI is part of the configuration.
  }
  if (std::string error = capture_->Start(); !error.empty()) {
    spdlog::critical("camera: {}", error);
    return kExitUnavailable;
  }
  spdlog::info("camera: {}", capture_->Describe());

  ControlSocketAccess access{.group = config_.control_group,
                             .mode = static_cast<unsigned>(config_.control_mode)};
  if (!config_.control_group_given && !access.group.empty() && !GroupExists(access.group)) {
    // A build tree's daemon run by hand: no package made the group (docs/exit_codes.md).
    spdlog::warn(
        "config: [control] group is not set and its default group '{}' does not exist (no "
        "package installed): the control socket keeps the daemon's own group",
        access.group);
    access.group.clear();
  }
  try {
    listen_fd_ = ListenControlSocket(config_.control_socket, access);
  } catch (const ControlAccessError& e) {
    spdlog::critical("config: {}", e.what());
    return kExitConfig;
  } catch (const ControlPathError& e) {
    spdlog::critical("{}", e.what());
    return kExitConfig;
  } catch (const ControlError& e) {
    spdlog::critical("{}", e.what());
    return kExitUnavailable;
  }
  struct stat bound {};
  if (::lstat(config_.control_socket.c_str(), &bound) == 0)
    socket_id_ = {bound.st_dev, bound.st_ino};
  AddFd(listen_fd_.get());
  if (config_.button_enabled) {
    triggers_.push_back(std::make_unique<GpioButton>(config_.button));
    if (std::string error = triggers_.back()->Open(); !error.empty()) {
      spdlog::critical("trigger: {}", error);
      return kExitUnavailable;
    }
  }
  for (const auto& trigger : triggers_) {
    AddFd(trigger->fd());
    spdlog::info("trigger: {}", trigger->Describe());
  }
  worker_ = std::make_unique<Worker>(config_, undistorter_.output_camera(), &spool_, &odometry_,
                                     done_event_.get());
  gate_ = std::make_unique<GateThread>(undistorter_, &session_, gate_event_.get());
  walk_ = std::make_unique<WalkThread>(config_, undistorter_, &spool_, walk_event_.get(),
                                       [this](const KeyframeInfo& first, const KeyframeInfo& last) {
                                         return odometry_.Lookup(config_, first, last);
                                       });

  // The worker loads the preview's GL driver before the daemon says it is ready, so neither the
  // first capture's critical path nor its gate (which it would slow into skipping frames) pays.
  worker_->WaitUntilWarmedUp();
  if (sd_watchdog_enabled(0, &watchdog_usec_) <= 0) watchdog_usec_ = 0;
  last_watchdog_ = std::chrono::steady_clock::now();
  spdlog::info("ready: control socket {}, spool {}", config_.control_socket.string(),
               spool_.dir().string());
  sd_notify(0, "READY=1");
  SetState(State::kIdle);
  return 0;
}

// The main loop: one event at a time, each to its handler (docs/architecture.md, data flow).
int Daemon::Run() {
  if (const int failed = Start(); failed != 0) return failed;

  epoll_event events[16];
  while (!stop_) {
    const int n = ::epoll_wait(epoll_.get(), events, 16, -1);
    if (n < 0) {
      if (errno == EINTR) continue;
      spdlog::critical("epoll_wait: {}", std::strerror(errno));
      return kExitSoftware;
    }
    for (int i = 0; i < n && !stop_; ++i) {
      const int fd = events[i].data.fd;
      if (fd == signal_fd_.get()) {
        OnSignals();
      } else if (fd == frame_event_.get()) {
        DrainEventFd(fd);
        OnFrame();
      } else if (fd == gate_event_.get()) {
        DrainEventFd(fd);
        OnGateDone();
      } else if (fd == walk_event_.get()) {
        DrainEventFd(fd);
        if (std::optional<std::string> fatal = walk_->fatal_error()) {
          spdlog::critical("internal error: {}", *fatal);
          return kExitSoftware;
        }
        OnWalkDone();
      } else if (fd == done_event_.get()) {
        DrainEventFd(fd);
        if (std::optional<std::string> fatal = worker_->fatal_error()) {
          spdlog::critical("internal error: {}", *fatal);
          return kExitSoftware;
        }
        OnJobDone();
      } else if (fd == timer_fd_.get()) {
        DrainEventFd(fd);
        OnTimer();
      } else if (Trigger* trigger = FindTrigger(fd)) {
        TriggerEvent event;
        std::string error;
        const int got = trigger->ReadEvent(&event, &error);
        if (got < 0) {
          spdlog::error("trigger: {}", error);
        } else if (got > 0) {
          OnTriggerEvent(trigger, event);
        }
      } else if (fd == listen_fd_.get()) {
        OnAccept();
      } else {
        OnClient(fd);
      }
    }
  }
  Shutdown();
  return 0;
}

void Daemon::OnTimer() {
  const auto now = std::chrono::steady_clock::now();
  EmitCameraChanges();
  hooks_.KillOverdue(now);  // Their ends arrive as SIGCHLD.
  if (state_ == State::kTracking &&
      session_.OnTime(NowSeconds()) == CaptureSession::Step::kFailed) {
    EndCapture(session_.failure_reason());
  }
  if (state_ == State::kWalking) {
    const WalkStatus walk = walk_->status();
    const CaptureStats stats = capture_->stats();
    if (!camera_failing_) camera_failing_since_.reset();
    if (camera_failing_ && !camera_failing_since_) camera_failing_since_ = now;
    if (!walk.finishing) {
      if (walk.seconds > config_.walk.timeout_s) {
        OnWalkStop("timer", "timeout");
      } else if (stats.end_of_stream) {
        OnWalkStop("camera", "camera ended");
      } else if (camera_failing_since_ && now - *camera_failing_since_ > kWalkCameraGrace) {
        OnWalkStop("camera", "camera lost");
      }
    }
  }
  if (watchdog_usec_ > 0 && now - last_watchdog_ > std::chrono::microseconds(watchdog_usec_ / 2)) {
    sd_notify(0, "WATCHDOG=1");
    last_watchdog_ = now;
  }
  if (accept_resume_ && now >= *accept_resume_) {
    accept_resume_.reset();
    AddFd(listen_fd_.get());
  }
  std::vector<int> idle;
  for (const auto& [fd, client] : clients_) {
    if (!client.watching && now - client.last_read > kClientIdleTimeout) idle.push_back(fd);
  }
  for (int fd : idle) {
    if (clients_.at(fd).request.buffered() == 0) {
      CloseClient(fd);
    } else {
      ReplyAndClose(fd, {{"ok", false},
                         {"error", "no end of line within " +
                                       std::to_string(kClientIdleTimeout.count()) + " s"}});
    }
  }
}

void Daemon::AddFd(int fd) {
  epoll_event ev{};
  ev.events = EPOLLIN;
  ev.data.fd = fd;
  if (::epoll_ctl(epoll_.get(), EPOLL_CTL_ADD, fd, &ev) != 0) {
    throw std::runtime_error(std::string("epoll_ctl: ") + std::strerror(errno));
  }
}

Trigger* Daemon::FindTrigger(int fd) const {
  for (const auto& trigger : triggers_) {
    if (trigger->fd() == fd) return trigger.get();
  }
  return nullptr;
}

void Daemon::SetState(State s) {
  if (s != state_) Emit({{"event", "state"}, {"state", Name(s)}, {"capture", captures_}});
  state_ = s;
  sd_notifyf(0, "STATUS=%s; %llu captures, %llu meshes", Name(s),
             static_cast<unsigned long long>(captures_),
             static_cast<unsigned long long>(succeeded_));
}

}  // namespace daemon_detail

int RunDaemon(const DaemonConfig& config) {
  BouguetCamera camera;
  try {
    camera = LoadCalibration(config.calibration);
  } catch (const CalibrationError& e) {
    spdlog::critical("{}", e.what());
    return daemon_detail::kExitConfig;
  }
  if (camera.width <= 0) {
    spdlog::critical("{}: image_size is required by the daemon", config.calibration.string());
    return daemon_detail::kExitConfig;
  }
  if (std::string problem = config.gate.Check(); !problem.empty()) {
    spdlog::critical("config: keyframes.{}", problem);
    return daemon_detail::kExitConfig;
  }
  // The event loop's top: construction too (the undistortion maps are made there, and OpenCV
  // throws cv::Exception on what it cannot allocate).
  try {
    daemon_detail::Daemon daemon(config, camera);
    return daemon.Run();
  } catch (const std::exception& e) {
    spdlog::critical("internal error: {}", e.what());
    return daemon_detail::kExitSoftware;
  } catch (...) {
    spdlog::critical("internal error: unknown exception");
    return daemon_detail::kExitSoftware;
  }
}

}  // namespace mm
