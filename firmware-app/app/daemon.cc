#include "app/daemon.h"

#include <signal.h>
#include <spdlog/spdlog.h>
#include <sys/epoll.h>
#include <sys/eventfd.h>
#include <sys/signalfd.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/timerfd.h>
#include <systemd/sd-daemon.h>

#include <algorithm>
#include <condition_variable>
#include <cstring>
#include <ctime>
#include <deque>
#include <map>
#include <mutex>
#include <nlohmann/json.hpp>
#include <optional>
#include <thread>
#include <vector>

#include "app/control.h"
#include "app/control_protocol.h"
#include "app/frame_info.h"
#include "app/gate_thread.h"
#include "app/hooks.h"
#include "app/pair_job.h"
#include "app/walk_thread.h"
#include "base/unique_fd.h"
#include "base/wall_clock.h"
#include "calib/calib_io.h"
#include "calib/undistort.h"
#include "capture/capture_thread.h"
#include "capture/source_uri.h"
#include "capture/trigger.h"
#include "entry/json_text.h"
#include "render/renderer.h"
#include "scale/odometry.h"
#include "session/capture_session.h"
#include "session/recent_frames.h"
#include "spool/spool.h"

namespace mm {
namespace {

using json = nlohmann::json;

// Exit codes (sysexits.h; docs/exit_codes.md is the table).
constexpr int kExitUnavailable = 69;  // EX_UNAVAILABLE: a device or the socket is not there yet.
constexpr int kExitSoftware = 70;     // EX_SOFTWARE: an internal error (a bug).
constexpr int kExitConfig = 78;       // EX_CONFIG: restarting will not help.

void SignalEventFd(int fd) {
  const uint64_t one = 1;
  [[maybe_unused]] const ssize_t n = ::write(fd, &one, sizeof(one));
}

void DrainEventFd(int fd) {
  uint64_t value = 0;
  [[maybe_unused]] const ssize_t n = ::read(fd, &value, sizeof(value));
}

struct Job {
  uint64_t capture_id = 0;
  FramePtr a;  // Raw frames, for the report.
  FramePtr b;
  cv::Mat undistorted_a;  // What the reconstruction sees.
  cv::Mat undistorted_b;
  std::vector<TrackCorrespondence> tracks;  // The gate's tracks from A to B.
  std::vector<SourceView> between;          // A frame about halfway, with the tracks at it.
  std::vector<KeyframeBTry> tries;          // This capture's B tries so far (the last is this B).
};

struct JobOutcome {
  uint64_t capture_id = 0;
  bool ok = false;
  std::string entry;
  std::string error;
  /// The reconstruction refused the pair (as opposed to a spool or internal error): the
  /// session decides whether a later B may follow.
  bool refused = false;
  TwoViewFailure failure = TwoViewFailure::kNone;
  std::string refusal;  // The reconstruction's reason.
  double seconds = 0.0;
};

// The robot's odometry (`odom` lines on the control socket): the event loop adds samples, the
// worker looks up the keyframes' positions once the stream has reached keyframe B's time.
class SharedOdometry {
 public:
  void Add(const OdometrySample& sample) {
    {
      std::lock_guard lock(mutex_);
      track_.Add(sample);
    }
    arrived_.notify_all();
  }

  /// The positions at keyframes `a` and `b`'s times on the clock of the `odom` timestamps
  /// ([scale] odometry_clock), after waiting up to max_odom_age_s for a sample at or after
  /// b's time (a bridge's latency); what is missing comes with its reason.
  PairScaleInputs Lookup(const DaemonConfig& config, const KeyframeInfo& a, const KeyframeInfo& b) {
    const auto time_of = [&](const KeyframeInfo& k) {
      return config.odometry_clock == DaemonConfig::OdometryClock::kCamera
                 ? k.source_time_s
                 : static_cast<double>(k.capture_realtime_ns) * 1e-9;
    };
    const double time_a_s = time_of(a), time_b_s = time_of(b);
    const OdometryLookupOptions options{.max_age_s = config.max_odom_age_s};
    const std::chrono::duration<double> wait(config.max_odom_age_s);
    std::unique_lock lock(mutex_);
    arrived_.wait_for(lock, wait,
                      [&] { return !track_.empty() && track_.newest().time_s >= time_b_s; });
    PairScaleInputs out;
    std::string why_a, why_b;
    out.odometry_a_m = track_.PositionAt(time_a_s, options, &why_a);
    out.odometry_b_m = track_.PositionAt(time_b_s, options, &why_b);
    if (!out.odometry_a_m) out.odometry_why_not = "keyframe A: " + why_a;
    if (!out.odometry_b_m) {
      out.odometry_why_not +=
          std::string(out.odometry_why_not.empty() ? "" : "; ") + "keyframe B: " + why_b;
    }
    return out;
  }

  nlohmann::json Describe() {
    std::lock_guard lock(mutex_);
    return {{"samples", track_.size()},
            {"newest_s", track_.empty() ? 0.0 : track_.newest().time_s}};
  }

 private:
  std::mutex mutex_;
  std::condition_variable arrived_;
  OdometryTrack track_;  // Guarded by mutex_.
};

// The reconstruction worker: a thread with a queue of at most one job.
class Worker {
 public:
  Worker(const DaemonConfig& config, const BouguetCamera& undistorted_camera, Spool* spool,
         SharedOdometry* odometry, int done_fd)
      : config_(config),
        recon_options_(AppliancePairOptions(config.recon)),
        camera_(undistorted_camera),
        spool_(spool),
        odometry_(odometry),
        done_fd_(done_fd) {
    thread_ = std::thread([this] { RunGuarded(); });
  }
  ~Worker() { Finish(); }
  Worker(const Worker&) = delete;
  Worker& operator=(const Worker&) = delete;

  /// Starts keyframe A's SIFT and the tracking of A's corners back through the frames before
  /// A (undistorted gray, newest first: source views before A for the dense stage) while the
  /// gate waits for B (the worker is idle then). A later Submit for the same capture uses the
  /// results.
  void Prepare(uint64_t capture_id, cv::Mat undistorted_a, std::vector<cv::Mat> frames_before_a) {
    std::lock_guard lock(mutex_);
    prepare_ = PrepareJob{capture_id, std::move(undistorted_a), std::move(frames_before_a)};
    cv_.notify_all();
  }

  /// Stops the thread after the job queued or running (a capture accepted is a capture
  /// finished: its outcome stays for TakeOutcome); a pending Prepare is dropped.
  void Finish() {
    {
      std::lock_guard lock(mutex_);
      stop_ = true;
    }
    cv_.notify_all();
    if (thread_.joinable()) thread_.join();
  }

  /// Returns once the worker has loaded the preview's GL driver (or failed to, or died).
  void WaitUntilWarmedUp() {
    std::unique_lock lock(mutex_);
    cv_.wait(lock, [&] { return warmed_up_; });
  }

  /// False when a job is already queued or running.
  bool Submit(Job job) {
    std::lock_guard lock(mutex_);
    if (job_ || busy_) return false;
    job_ = std::move(job);
    cv_.notify_all();
    return true;
  }

  /// Set when an exception reached the thread's top (the thread has ended): the daemon exits 70.
  std::optional<std::string> fatal_error() {
    std::lock_guard lock(mutex_);
    return fatal_error_;
  }

  std::optional<JobOutcome> TakeOutcome() {
    std::lock_guard lock(mutex_);
    if (outcomes_.empty()) return std::nullopt;
    JobOutcome o = std::move(outcomes_.front());
    outcomes_.pop_front();
    return o;
  }

 private:
  // An exception leaving a std::thread calls std::terminate (SIGABRT, restarted forever by
  // systemd): it is caught here, kept for the loop and reported through the done eventfd.
  void RunGuarded() {
    std::string fatal;
    try {
      Run();
      return;
    } catch (const std::exception& e) {
      fatal = std::string("worker: ") + e.what();
    } catch (...) {
      fatal = "worker: unknown exception";
    }
    {
      std::lock_guard lock(mutex_);
      fatal_error_ = std::move(fatal);
    }
    MarkWarmedUp();
    SignalEventFd(done_fd_);
  }

  void MarkWarmedUp() {
    {
      std::lock_guard lock(mutex_);
      warmed_up_ = true;
    }
    cv_.notify_all();
  }

  void Run() {
    // The preview's GL driver is loaded on this thread, so its allocations stay in the
    // worker's malloc arena (on the main thread they raised the peak RSS by about 5 MB).
    if (const std::string error = WarmUpRenderer(); !error.empty()) {
      spdlog::warn("preview renderer unavailable (entries get no preview.png): {}", error);
    }
    MarkWarmedUp();
    for (;;) {
      Job job;
      {
        std::unique_lock lock(mutex_);
        cv_.wait(lock, [&] { return stop_ || job_.has_value() || prepare_.has_value(); });
        if (stop_ && !job_.has_value()) return;
        if (prepare_.has_value() && !stop_) {
          PrepareJob prepare = std::move(*prepare_);
          prepare_.reset();
          lock.unlock();
          Features features;
          std::vector<SourceView> views_before_a;
          try {
            features = ExtractKeyframeFeatures(prepare.image, recon_options_);
            if (recon_options_.mesh_mode == MeshMode::kDense) {
              views_before_a =
                  ViewsBeforeA(ToGray(prepare.image), prepare.frames_before_a, config_.gate);
            }
          } catch (const std::exception& e) {
            // Not fatal: Process extracts A's features again and reports its own failure.
            spdlog::error("capture {}: keyframe A features: {}", prepare.capture_id, e.what());
            lock.lock();
            continue;
          }
          lock.lock();
          features_ = std::move(features);
          views_before_a_ = std::move(views_before_a);
          features_capture_ = prepare.capture_id;
          continue;
        }
        job = std::move(*job_);
        job_.reset();
        busy_ = true;
      }
      JobOutcome outcome = Process(job);
      {
        std::lock_guard lock(mutex_);
        busy_ = false;
        outcomes_.push_back(std::move(outcome));
      }
      SignalEventFd(done_fd_);
    }
  }

  JobOutcome Process(const Job& job) {
    const auto start = std::chrono::steady_clock::now();
    JobOutcome outcome;
    outcome.capture_id = job.capture_id;
    try {
      Features features_a;
      bool have_features = false;
      std::vector<SourceView> views = job.between;
      {
        std::lock_guard lock(mutex_);
        // Copied, not moved: a refused B may be followed by a later one from the same A.
        if (features_capture_ == job.capture_id) {
          features_a = features_;
          have_features = true;
          views.insert(views.end(), views_before_a_.begin(), views_before_a_.end());
        }
      }
      const KeyframeInfo a = KeyframeInfoOf(*job.a), b = KeyframeInfoOf(*job.b);
      PairScaleInputs scale;
      if (config_.scale.source == ScaleSource::kOdometry ||
          config_.scale.source == ScaleSource::kAuto) {
        scale = odometry_->Lookup(config_, a, b);
      }
      scale.options = config_.scale;
      PairJobResult result =
          RunPairJob(job.undistorted_a, job.undistorted_b, a, b, camera_, recon_options_,
                     have_features ? &features_a : nullptr, job.tracks, views, job.tries, scale);
      if (!result.ok) {
        outcome.error = "reconstruction failed: " + result.error;
        outcome.refused = true;
        outcome.failure = result.recon.geometry.failure;
        outcome.refusal = result.error;
      } else {
        const SpoolCommit commit = WriteEntry(*spool_, result.entry, std::time(nullptr));
        if (commit.ok) {
          outcome.ok = true;
          outcome.entry = commit.entry.string();
          if (!commit.error.empty()) spdlog::warn("spool: {}", commit.error);
          if (commit.removed_by_retention > 0) {
            spdlog::info("spool: retention removed {} old entries", commit.removed_by_retention);
          }
        } else {
          outcome.error = "spool write failed: " + commit.error;
        }
      }
    } catch (const std::exception& e) {
      outcome.error = std::string("internal error: ") + e.what();
    }
    outcome.seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    return outcome;
  }

  // The appliance's memory policy on the configured options: the SIFT pyramid (about 100 MB
  // at 640x480) is freed once B's features are out, so it is not held through the dense
  // stage and the rendering (peak RSS at 640x480: 296 -> 199 MiB); A's SIFT of the next
  // capture, computed while the gate waits for B, allocates it again.
  static PairOptions AppliancePairOptions(PairOptions options) {
    options.release_sift_workspace_after_b = true;
    return options;
  }

  const DaemonConfig& config_;
  const PairOptions recon_options_;
  BouguetCamera camera_;  // Of the undistorted frames.
  Spool* spool_;
  SharedOdometry* odometry_;
  int done_fd_;
  std::thread thread_;
  std::mutex mutex_;
  std::condition_variable cv_;
  bool stop_ = false;  // Guarded by mutex_.
  bool busy_ = false;  // Guarded by mutex_.
  bool warmed_up_ = false;  // Guarded by mutex_: the GL driver is loaded (or failed to).
  struct PrepareJob {
    uint64_t capture_id = 0;
    cv::Mat image;
    std::vector<cv::Mat> frames_before_a;
  };
  std::optional<Job> job_;                  // Guarded by mutex_.
  std::optional<PrepareJob> prepare_;       // Guarded by mutex_.
  Features features_;                       // Keyframe A's, guarded by mutex_.
  std::vector<SourceView> views_before_a_;  // Keyframe A's, guarded by mutex_.
  uint64_t features_capture_ = 0;           // Whose features_ are; guarded by mutex_.
  std::deque<JobOutcome> outcomes_;         // Guarded by mutex_.
  std::optional<std::string> fatal_error_;  // Guarded by mutex_.
};

// The control protocol's limits (control.h): one request line per connection.
constexpr auto kClientIdleTimeout = std::chrono::seconds(5);  // A held connection is closed.
constexpr size_t kMaxClients = 32;  // At the cap, the one idle longest makes room.
// Watchers hold their slots (they are never idle-closed or evicted), so they are capped below
// the table: requests always find room.
constexpr size_t kMaxWatchers = 8;
// Gate progress events while tracking, at most this often (the gate sees every frame).
constexpr auto kGateEventPeriod = std::chrono::milliseconds(200);
constexpr auto kAcceptBackoff = std::chrono::milliseconds(200);  // After EMFILE / ENFILE.
// A walk ends when the camera has failed this long without a frame ("camera lost").
constexpr auto kWalkCameraGrace = std::chrono::seconds(2);

// A control-socket client: the request line is collected across reads (a command may arrive in
// several pieces).
struct Client {
  UniqueFd fd;
  ControlRequestReader request;
  std::chrono::steady_clock::time_point last_read;
  bool watching = false;  // Subscribed with `watch`: gets the events, sends nothing more.
};

enum class State { kIdle, kTracking, kReconstructing, kWalking };

const char* Name(State s) {
  switch (s) {
    case State::kIdle:
      return "idle";
    case State::kTracking:
      return "tracking";
    case State::kReconstructing:
      return "reconstructing";
    case State::kWalking:
      return "walking";
  }
  return "?";
}

class Daemon {
 public:
  Daemon(const DaemonConfig& config, const BouguetCamera& camera)
      : config_(config),
        undistorter_(camera),
        session_(undistorter_.output_camera().K(),
                 CaptureSessionOptions{.gate = config.gate,
                                       .timeout_s = config.keyframe_timeout_s,
                                       .max_tries = config.max_b_tries}),
        spool_({.dir = config.spool_dir, .max_entries = config.spool_max_entries}),
        hooks_(config.hooks) {}

  int Run();

 private:
  void OnTrigger(const char* origin, json* reply);
  json OnWalkStart(const char* origin);
  json OnWalkStop(const char* origin, const std::string& reason);
  void OnWalkDone();
  void OnTriggerEvent(Trigger* trigger, const TriggerEvent& event);
  void OnFrame();
  void OnGateDone();
  void ApplyGate(const TrackedFrame& tracked);
  void SettleGate();
  void OnJobDone();
  void OnTimer();
  void OnAccept();
  void PauseAccept();
  void OnClient(int fd);
  json Answer(const std::string& request);
  json OnOdom(const std::string& line);
  void OnWatch(int fd);
  void Emit(json event);
  void EmitCameraChanges();
  static void LogHookStart(const HookStart& start);
  void OnHooksEnded();
  void FinishOnStop();
  void ReplyAndClose(int fd, const json& reply);
  void CloseClient(int fd);
  json Status();
  void SetState(State s);
  void EndCapture(const std::string& error);
  void AddFd(int fd);
  Trigger* FindTrigger(int fd) const;
  static double NowSeconds();  // The session's clock (steady).
  static double FrameTimeSeconds(const Frame& frame);  // Its capture time (CLOCK_MONOTONIC).
  void KeepRecentFrame();  // The newest frame into recent_frames_ (gray, as captured).

  const DaemonConfig& config_;
  Undistorter undistorter_;
  CaptureSession session_;
  Spool spool_;
  HookRunner hooks_;
  UniqueFd epoll_;
  UniqueFd frame_event_;
  UniqueFd done_event_;
  UniqueFd gate_event_;
  UniqueFd walk_event_;
  UniqueFd signal_fd_;
  UniqueFd timer_fd_;
  UniqueFd listen_fd_;
  std::pair<dev_t, ino_t> socket_id_{};  // The bound socket file's device and inode.
  std::map<int, Client> clients_;
  // Accepting paused until then (the fd limit was reached: the pending connection would keep
  // the listen socket readable and the loop spinning).
  std::optional<std::chrono::steady_clock::time_point> accept_resume_;
  bool accept_failing_ = false;  // Logged once until an accept succeeds again.
  std::unique_ptr<CaptureThread> capture_;
  std::vector<std::unique_ptr<Trigger>> triggers_;  // SIGUSR1, the GPIO button when configured.
  SharedOdometry odometry_;                         // Before worker_, which uses it until it ends.
  std::unique_ptr<Worker> worker_;
  std::unique_ptr<GateThread> gate_;  // Before session_ goes: declared after it.
  std::unique_ptr<WalkThread> walk_;
  uint64_t walks_ = 0;
  uint64_t last_walk_sequence_ = 0;  // The newest frame offered to the walk.
  json last_walk_ = nullptr;
  // The GPIO button's last press (CLOCK_MONOTONIC ns), when long presses are told apart.
  std::optional<int64_t> press_time_ns_;
  std::optional<std::chrono::steady_clock::time_point> camera_failing_since_;

  State state_ = State::kIdle;
  uint64_t captures_ = 0;
  std::string last_trigger_;  // Origin of the last accepted trigger, e.g. "SIGUSR1".
  uint64_t succeeded_ = 0;
  FramePtr keyframe_a_;
  cv::Mat undistorted_a_;
  uint64_t last_tracked_sequence_ = 0;
  // Frames of the last seconds (gray, as captured), for views before A.
  RecentFrames recent_frames_;
  uint64_t last_recent_sequence_ = 0;
  json last_result_ = nullptr;
  uint64_t watchdog_usec_ = 0;
  std::chrono::steady_clock::time_point last_watchdog_;
  uint64_t events_ = 0;  // Events emitted (each carries its number, `seq`).
  std::chrono::steady_clock::time_point last_gate_event_;
  uint64_t camera_errors_seen_ = 0;  // CaptureStats::errors at the last camera event.
  uint64_t camera_frames_seen_ = 0;
  bool camera_failing_ = false;  // An error since the last frame.
  bool camera_ended_ = false;
  bool stop_ = false;
  bool stopping_ = false;  // Set once the loop has ended: results end captures, start nothing.
};

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

int Daemon::Run() {
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
        signalfd_siginfo info{};
        while (::read(fd, &info, sizeof(info)) == sizeof(info)) {
          if (info.ssi_signo == SIGCHLD) {
            OnHooksEnded();
          } else if (info.ssi_signo == SIGHUP) {
            spdlog::info("SIGHUP ignored (restart the service to reload the config)");
          } else {
            spdlog::info("signal {}: stopping", info.ssi_signo);
            stop_ = true;
          }
        }
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
  sd_notify(0, "STOPPING=1");
  FinishOnStop();
  Emit({{"event", "stopped"}});
  capture_->Stop();
  // Only the socket this daemon bound (not a file put there since).
  struct stat now {};
  if (::lstat(config_.control_socket.c_str(), &now) == 0 && S_ISSOCK(now.st_mode) &&
      std::pair(now.st_dev, now.st_ino) == socket_id_) {
    ::unlink(config_.control_socket.c_str());
  }
  spdlog::info("stopped");
  return 0;
}

void Daemon::FinishOnStop() {
  stopping_ = true;
  if (state_ == State::kWalking) {
    // The walk's entry is written with what it has (the unit's TimeoutStopSec allows for it).
    spdlog::info("stopping: walk {} ends; its entry is written first", walks_);
    walk_->Stop("daemon stopping");
    walk_->WaitFinished();
    OnWalkDone();
  }
  if (state_ == State::kReconstructing) {
    // The unit's TimeoutStopSec leaves the pair (seconds on a board) time to finish.
    spdlog::info("stopping: capture {} is being reconstructed; its entry is finished first",
                 captures_);
    worker_->Finish();  // An entry is committed whole or not at all.
    OnJobDone();
  } else if (state_ == State::kTracking) {
    spdlog::warn("capture {} abandoned: stopped while tracking, before keyframe B", captures_);
    Emit({{"event", "capture_abandoned"},
          {"capture", captures_},
          {"error", "stopped while tracking, before keyframe B"}});
  }
  walk_.reset();
  gate_.reset();  // After OnJobDone, which settles the gate first.
  worker_.reset();
}

void Daemon::OnTrigger(const char* origin, json* reply) {
  // Every refusal is answered, logged and emitted.
  const auto refuse = [&](const std::string& error) {
    *reply = {{"ok", false}, {"error", error}};
    Emit({{"event", "trigger_refused"}, {"origin", origin}, {"error", error}});
  };
  if (state_ != State::kIdle) {
    refuse(std::string("busy: ") + Name(state_));
    spdlog::warn("trigger ({}) refused: busy {}", origin, Name(state_));
    return;
  }
  // A frame of an ended capture may still be in the gate: finished first, its result dropped.
  gate_->WaitIdle();
  (void)gate_->Take();
  FramePtr latest = capture_->Latest();
  if (!latest) {
    refuse("no frame from the camera yet");
    spdlog::warn("trigger ({}) refused: no frame yet", origin);
    return;
  }
  cv::Mat undistorted;
  try {
    undistorted = undistorter_.Apply(latest->image);
  } catch (const std::exception& e) {
    refuse(std::string("frame does not fit the calibration: ") + e.what());
    spdlog::error("trigger ({}) refused: {}", origin, e.what());
    return;
  }
  ++captures_;
  last_trigger_ = origin;
  keyframe_a_ = std::move(latest);
  undistorted_a_ = undistorted;
  last_tracked_sequence_ = keyframe_a_->sequence;
  const int corners = session_.Start(ToGray(undistorted_a_), NowSeconds());
  // The frames kept from before A, undistorted as A (the worker tracks A's corners back).
  std::vector<cv::Mat> frames_before_a;
  for (const cv::Mat& gray : recent_frames_.BeforeA(FrameTimeSeconds(*keyframe_a_))) {
    try {
      frames_before_a.push_back(undistorter_.Apply(gray));
    } catch (const std::exception& e) {
      spdlog::warn("capture {}: a frame before A does not fit the calibration: {}", captures_,
                   e.what());
    }
  }
  worker_->Prepare(captures_, undistorted_a_, std::move(frames_before_a));
  spdlog::info("capture {} ({}): keyframe A = frame {} ({}), {} corners to track", captures_,
               origin, keyframe_a_->sequence, keyframe_a_->source_id, corners);
  Emit({{"event", "keyframe_a"},
        {"capture", captures_},
        {"origin", origin},
        {"frame", keyframe_a_->sequence},
        {"source", keyframe_a_->source_id},
        {"corners", corners}});
  SetState(State::kTracking);
  *reply = {{"ok", true}, {"capture", captures_}};
}

// The GPIO button with [trigger] long_press_ms: a press held that long starts or stops a walk, a
// shorter one is a capture (both at the release). Otherwise a press is a capture at once.
void Daemon::OnTriggerEvent(Trigger* trigger, const TriggerEvent& event) {
  const bool gestures = config_.long_press_ms > 0 && dynamic_cast<GpioButton*>(trigger) != nullptr;
  if (!gestures) {
    if (event.pressed) {
      json reply;
      OnTrigger(event.source.c_str(), &reply);
    }
    return;
  }
  if (event.pressed) {
    press_time_ns_ = event.time_ns;
    return;
  }
  if (!press_time_ns_) return;  // A release without its press (held at the start).
  const int64_t held_ns = event.time_ns - *press_time_ns_;
  press_time_ns_.reset();
  if (held_ns >= int64_t{config_.long_press_ms} * 1'000'000) {
    const std::string origin = event.source + " (long press)";
    const json reply = state_ == State::kWalking ? OnWalkStop(origin.c_str(), "operator")
                                                 : OnWalkStart(origin.c_str());
    if (!reply.value("ok", false)) {
      spdlog::warn("{}: {}", origin, reply.value("error", std::string()));
    }
    return;
  }
  json reply;
  OnTrigger(event.source.c_str(), &reply);
}

json Daemon::OnWalkStart(const char* origin) {
  const auto refuse = [&](const std::string& error) {
    spdlog::warn("walk start ({}) refused: {}", origin, error);
    Emit({{"event", "walk_refused"}, {"origin", origin}, {"error", error}});
    return json{{"ok", false}, {"error", error}};
  };
  if (state_ != State::kIdle) return refuse(std::string("busy: ") + Name(state_));
  if (walk_->status().walking) return refuse("busy: the last walk's entry is being written");
  FramePtr latest = capture_->Latest();
  if (!latest) return refuse("no frame from the camera yet");
  ++walks_;
  last_walk_sequence_ = latest->sequence;
  spdlog::info("walk {} ({}): started at frame {} ({})", walks_, origin, latest->sequence,
               latest->source_id);
  Emit({{"event", "walk_started"},
        {"walk", walks_},
        {"origin", origin},
        {"frame", latest->sequence}});
  walk_->Start(walks_, std::move(latest));
  SetState(State::kWalking);
  return {{"ok", true}, {"walk", walks_}};
}

json Daemon::OnWalkStop(const char* origin, const std::string& reason) {
  if (state_ != State::kWalking) {
    const std::string error = std::string("not walking (") + Name(state_) + ")";
    spdlog::warn("walk stop ({}) refused: {}", origin, error);
    return {{"ok", false}, {"error", error}};
  }
  const WalkStatus w = walk_->status();
  if (w.finishing) return {{"ok", false}, {"error", "walk already stopping"}};
  spdlog::info("walk {}: stopped ({}, {}) after {} keyframes; writing its entry", w.walk, origin,
               reason, w.keyframes);
  Emit({{"event", "walk_stopping"},
        {"walk", w.walk},
        {"reason", reason},
        {"keyframes", w.keyframes}});
  walk_->Stop(reason);
  return {{"ok", true}, {"walk", w.walk}, {"keyframes", w.keyframes}};
}

void Daemon::OnWalkDone() {
  for (const WalkKeyframeSummary& k : walk_->TakeKeyframes()) {
    if (!k.failure.empty()) {
      spdlog::warn("walk {}: keyframe {} starts segment {}: {}", walks_, k.index, k.segment,
                   k.failure);
    } else {
      spdlog::info("walk {}: keyframe {} registered ({} PnP inliers, {} new points, {:.3f} s)",
                   walks_, k.index, k.pnp_inliers, k.new_points, k.time_s);
    }
    Emit({{"event", "walk_keyframe"},
          {"walk", walks_},
          {"keyframe", k.index},
          {"segment", k.segment},
          {"registered", k.registered},
          {"failure", k.failure},
          {"pnp_inliers", k.pnp_inliers},
          {"new_points", k.new_points},
          {"seconds", k.time_s}});
  }
  while (std::optional<WalkOutcome> o = walk_->TakeOutcome()) {
    if (o->ok) {
      spdlog::info(
          "walk {}: map written to {} ({} keyframes, {} registered, {} segments; "
          "{:.2f} s; ended by {})",
          o->walk, o->entry, o->keyframes, o->registered, o->segments, o->seconds, o->stop_reason);
      Emit({{"event", "walk_entry"},
            {"walk", o->walk},
            {"entry", o->entry},
            {"keyframes", o->keyframes},
            {"registered", o->registered},
            {"segments", o->segments},
            {"reason", o->stop_reason},
            {"seconds", o->seconds}});
      LogHookStart(hooks_.OnEntry(o->entry, o->walk));
    } else {
      spdlog::error("walk {}: {}", o->walk, o->error);
      Emit({{"event", "walk_failed"}, {"walk", o->walk}, {"error", o->error}});
      LogHookStart(hooks_.OnFailure(o->error, o->walk));
    }
    last_walk_ = {{"walk", o->walk},
                  {"ok", o->ok},
                  {"entry", o->entry},
                  {"error", o->error},
                  {"reason", o->stop_reason},
                  {"keyframes", o->keyframes},
                  {"registered", o->registered},
                  {"segments", o->segments}};
    if (state_ == State::kWalking) SetState(State::kIdle);
  }
  OnFrame();  // A newer frame may be waiting.
}

double Daemon::NowSeconds() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

void Daemon::EndCapture(const std::string& error) {
  spdlog::error("capture {}: {}", captures_, error);
  Emit({{"event", "capture_failed"}, {"capture", captures_}, {"error", error}});
  LogHookStart(hooks_.OnFailure(error, captures_));
  session_.Abort(error);
  last_result_ = {{"capture", captures_},
                  {"ok", false},
                  {"error", error},
                  {"b_tries", session_.tries().size()}};
  keyframe_a_.reset();
  undistorted_a_.release();
  SetState(State::kIdle);
}

void Daemon::OnFrame() {
  if (state_ == State::kWalking) {
    // The walk thread takes the newest frame when it is free (the others are skipped).
    FramePtr frame = capture_->Latest();
    if (frame && frame->sequence > last_walk_sequence_ && walk_->Offer(frame)) {
      last_walk_sequence_ = frame->sequence;
    }
    return;
  }
  KeepRecentFrame();
  // Frames feed the session while a capture is open, also while a B is being reconstructed
  // (the tracks stay alive for a later B if that one is refused). The gate thread tracks A's
  // corners into the newest frame when it is free (frames that arrive meanwhile are skipped;
  // KLT's pyramid absorbs the larger step, and a jump it cannot goes to the reconstruction).
  if (!session_.wants_frames() || gate_->busy()) return;
  FramePtr frame = capture_->Latest();
  if (!frame || frame->sequence <= last_tracked_sequence_) return;
  last_tracked_sequence_ = frame->sequence;
  gate_->Post(captures_, std::move(frame));
}

void Daemon::KeepRecentFrame() {
  FramePtr frame = capture_->Latest();
  if (!frame || frame->sequence <= last_recent_sequence_) return;
  last_recent_sequence_ = frame->sequence;
  const double time_s = FrameTimeSeconds(*frame);
  if (recent_frames_.Keeps(time_s)) recent_frames_.Add(ToGray(frame->image), time_s);
}

double Daemon::FrameTimeSeconds(const Frame& frame) {
  return 1e-9 * static_cast<double>(frame.capture_time_ns);
}

void Daemon::OnGateDone() {
  if (std::optional<TrackedFrame> tracked = gate_->Take()) {
    if (tracked->capture_id == captures_) ApplyGate(*tracked);
  }
  OnFrame();  // A newer frame may be waiting.
}

// Before the session's gate-touching calls (OnResult): the frame in the gate finishes, and its
// decision is applied first (with a B in flight, it only keeps the tracks or marks them lost).
void Daemon::SettleGate() {
  gate_->WaitIdle();
  if (std::optional<TrackedFrame> tracked = gate_->Take()) {
    if (tracked->capture_id == captures_) ApplyGate(*tracked);
  }
}

void Daemon::ApplyGate(const TrackedFrame& tracked) {
  if (!session_.open()) return;
  if (!tracked.error.empty()) {
    if (state_ == State::kTracking) {
      EndCapture("frame does not fit the calibration: " + tracked.error);
    }
    return;
  }
  const FramePtr& frame = tracked.frame;
  const CaptureSession::Step step =
      session_.OnTracked(tracked.decision, frame->sequence, NowSeconds(),
                         /*can_submit=*/state_ == State::kTracking);
  const GateDecision& d = session_.last_decision();
  spdlog::debug("capture {}: frame {}: {} tracks, parallax {:.3f} deg: {}", captures_,
                frame->sequence, d.tracks, d.median_parallax_deg, d.reason);
  if (step == CaptureSession::Step::kFailed) {
    EndCapture(session_.failure_reason());
    return;
  }
  if (step != CaptureSession::Step::kSubmitB) {
    const auto now = std::chrono::steady_clock::now();
    if (state_ == State::kTracking && now - last_gate_event_ >= kGateEventPeriod) {
      last_gate_event_ = now;
      Emit({{"event", "gate"},
            {"capture", captures_},
            {"frame", frame->sequence},
            {"tracks", d.tracks},
            {"parallax_deg", d.median_parallax_deg},
            {"target_deg", config_.gate.parallax_deg},
            {"reason", d.reason}});
    }
    return;
  }
  const std::string try_note =
      session_.tries().size() > 1 ? fmt::format(" (try {})", session_.tries().size()) : "";
  if (session_.tries().back().after_lost_track) {
    spdlog::info("capture {}: keyframe B = frame {} ({}) as the tracks broke ({}){}", captures_,
                 frame->sequence, frame->source_id, d.reason, try_note);
  } else {
    spdlog::info("capture {}: keyframe B = frame {} ({}), parallax {:.2f} deg, {} inliers{}",
                 captures_, frame->sequence, frame->source_id, d.median_parallax_deg,
                 d.essential_inliers, try_note);
  }
  Emit({{"event", "keyframe_b"},
        {"capture", captures_},
        {"frame", frame->sequence},
        {"source", frame->source_id},
        {"parallax_deg", d.median_parallax_deg},
        {"inliers", d.essential_inliers},
        {"after_lost_track", session_.tries().back().after_lost_track},
        {"try", session_.tries().size()}});
  Job job{captures_,          keyframe_a_,         frame,
          undistorted_a_,     tracked.undistorted, session_.Tracks(),
          session_.Between(), session_.tries()};
  if (!worker_->Submit(std::move(job))) {
    EndCapture("worker busy; capture dropped");
    return;
  }
  SetState(State::kReconstructing);
}

void Daemon::OnJobDone() {
  SettleGate();  // OnResult may raise the gate's target.
  while (std::optional<JobOutcome> o = worker_->TakeOutcome()) {
    if (o->capture_id != captures_ || !session_.open()) continue;  // A capture already ended.
    if (o->refused) {
      const CaptureSession::Step step = session_.OnResult(false, o->failure, o->refusal);
      if (step == CaptureSession::Step::kWait && stopping_) {
        spdlog::warn("capture {} abandoned: keyframe B refused ({}) while stopping", o->capture_id,
                     o->refusal);
        Emit({{"event", "capture_abandoned"},
              {"capture", o->capture_id},
              {"error", "keyframe B refused (" + o->refusal + ") while stopping"}});
        continue;
      }
      if (step == CaptureSession::Step::kWait) {
        spdlog::info("capture {}: keyframe B refused ({}); tracking on for a later B",
                     o->capture_id, o->refusal);
        Emit({{"event", "keyframe_b_refused"}, {"capture", o->capture_id}, {"reason", o->refusal}});
        SetState(State::kTracking);
        OnFrame();
        continue;
      }
      EndCapture(session_.failure_reason());
      continue;
    }
    session_.OnResult(true, TwoViewFailure::kNone, {});
    if (o->ok) {
      ++succeeded_;
      spdlog::info("capture {}: mesh written to {} ({:.2f} s, {} B tried)", o->capture_id, o->entry,
                   o->seconds, session_.tries().size());
      Emit({{"event", "entry"},
            {"capture", o->capture_id},
            {"entry", o->entry},
            {"seconds", o->seconds},
            {"b_tries", session_.tries().size()}});
      LogHookStart(hooks_.OnEntry(o->entry, o->capture_id));
    } else {
      spdlog::error("capture {}: {}", o->capture_id, o->error);
      Emit({{"event", "capture_failed"}, {"capture", o->capture_id}, {"error", o->error}});
      LogHookStart(hooks_.OnFailure(o->error, o->capture_id));
    }
    last_result_ = {{"capture", o->capture_id}, {"ok", o->ok},
                    {"entry", o->entry},        {"error", o->error},
                    {"seconds", o->seconds},    {"b_tries", session_.tries().size()}};
    keyframe_a_.reset();
    undistorted_a_.release();
    SetState(State::kIdle);
  }
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

void Daemon::OnAccept() {
  for (;;) {
    const int client = ::accept4(listen_fd_.get(), nullptr, nullptr, SOCK_NONBLOCK | SOCK_CLOEXEC);
    if (client < 0) {
      if (errno == EINTR || errno == ECONNABORTED) continue;
      if (errno == EMFILE || errno == ENFILE || errno == ENOBUFS || errno == ENOMEM) {
        PauseAccept();
      }
      return;  // EAGAIN: none pending.
    }
    UniqueFd fd(client);
    accept_failing_ = false;
    if (clients_.size() >= kMaxClients) {
      // At the cap, first read what the held clients have sent: a request waiting is served
      // and a client that hung up (a connect storm) is closed, freeing its slot.
      std::vector<int> held;
      for (const auto& [held_fd, c] : clients_) held.push_back(held_fd);
      for (int held_fd : held) OnClient(held_fd);
    }
    if (clients_.size() >= kMaxClients) {
      // Still full: the client idle longest makes room. A flood of idle connections cycles
      // through the slots while a client that asks is served.
      // Watchers are not idle (kMaxWatchers < kMaxClients leaves requests to choose from).
      const auto oldest =
          std::min_element(clients_.begin(), clients_.end(), [](const auto& a, const auto& b) {
            return std::pair(a.second.watching, a.second.last_read) <
                   std::pair(b.second.watching, b.second.last_read);
          });
      ReplyAndClose(oldest->first,
                    {{"ok", false},
                     {"error", "busy: " + std::to_string(kMaxClients) +
                                   " clients connected; this one was idle longest"}});
    }
    AddFd(client);
    clients_.emplace(
        client, Client{std::move(fd), ControlRequestReader(), std::chrono::steady_clock::now()});
  }
}

void Daemon::PauseAccept() {
  if (!accept_failing_) {
    spdlog::warn("control socket: accept: {}; accepting again every {} ms until it succeeds",
                 std::strerror(errno), kAcceptBackoff.count());
    accept_failing_ = true;
  }
  ::epoll_ctl(epoll_.get(), EPOLL_CTL_DEL, listen_fd_.get(), nullptr);
  accept_resume_ = std::chrono::steady_clock::now() + kAcceptBackoff;
}

void Daemon::CloseClient(int fd) {
  ::epoll_ctl(epoll_.get(), EPOLL_CTL_DEL, fd, nullptr);
  clients_.erase(fd);
}

void Daemon::ReplyAndClose(int fd, const json& reply) {
  const std::string line = JsonText(reply) + "\n";
  [[maybe_unused]] const ssize_t w = ::send(fd, line.data(), line.size(), MSG_NOSIGNAL);
  CloseClient(fd);
}

void Daemon::OnClient(int fd) {
  const auto it = clients_.find(fd);
  if (it == clients_.end()) return;  // Closed earlier in this batch of events.
  Client& client = it->second;
  char buf[512];
  if (client.watching) {
    // A watcher only listens: what it sends is read and dropped; its hang-up closes it.
    for (;;) {
      const ssize_t n = ::recv(fd, buf, sizeof(buf), 0);
      if (n > 0) continue;
      if (n < 0 && errno == EINTR) continue;
      if (n == 0 || (errno != EAGAIN && errno != EWOULDBLOCK)) CloseClient(fd);
      return;
    }
  }
  for (;;) {
    const ssize_t n = ::recv(fd, buf, sizeof(buf), 0);
    ControlRequestReader::Status status;
    if (n > 0) {
      client.last_read = std::chrono::steady_clock::now();
      status = client.request.Append(std::string_view(buf, static_cast<size_t>(n)));
    } else if (n == 0) {
      status = client.request.Finish();
    } else {
      if (errno == EINTR) continue;
      if (errno != EAGAIN && errno != EWOULDBLOCK) CloseClient(fd);
      return;  // EAGAIN: the rest of the line comes later.
    }
    // An `odom` line is answered and the connection stays for the next (a robot's bridge
    // writes them continuously); any other command is answered and the connection closed.
    std::string odom_replies;
    while (status == ControlRequestReader::Status::kComplete &&
           ParseControlCommand(client.request.request()) == ControlCommand::kOdom) {
      odom_replies += JsonText(OnOdom(client.request.request())) + "\n";
      status = client.request.Next();
    }
    if (!odom_replies.empty()) {
      // One send for the lines of one read. A bridge that never reads its answers loses them
      // once its socket buffer is full (EAGAIN), not its connection.
      [[maybe_unused]] const ssize_t w =
          ::send(fd, odom_replies.data(), odom_replies.size(), MSG_NOSIGNAL | MSG_DONTWAIT);
    }
    switch (status) {
      case ControlRequestReader::Status::kNeedMore:
        continue;
      case ControlRequestReader::Status::kComplete:
        if (ParseControlCommand(client.request.request()) == ControlCommand::kWatch) {
          OnWatch(fd);
        } else {
          ReplyAndClose(fd, Answer(client.request.request()));
        }
        return;
      case ControlRequestReader::Status::kTooLong:
        ReplyAndClose(fd,
                      {{"ok", false},
                       {"error", "request longer than " + std::to_string(kMaxControlRequestBytes) +
                                     " bytes without an end of line"}});
        return;
      case ControlRequestReader::Status::kEmpty:
        CloseClient(fd);
        return;
    }
  }
}

void Daemon::OnWatch(int fd) {
  const size_t watchers = static_cast<size_t>(std::count_if(
      clients_.begin(), clients_.end(), [](const auto& c) { return c.second.watching; }));
  if (watchers >= kMaxWatchers) {
    ReplyAndClose(fd, {{"ok", false},
                       {"error", "busy: " + std::to_string(kMaxWatchers) + " watchers connected"}});
    return;
  }
  // The reply says where things stand, so a watcher needs no status request besides.
  const std::string line =
      JsonText({{"ok", true}, {"watching", true}, {"seq", events_}, {"status", Status()}}) + "\n";
  if (::send(fd, line.data(), line.size(), MSG_NOSIGNAL | MSG_DONTWAIT) !=
      static_cast<ssize_t>(line.size())) {
    CloseClient(fd);
    return;
  }
  clients_.at(fd).watching = true;
}

// One JSON line to every watcher, numbered and stamped with the wall clock. A watcher whose
// socket buffer is full (it stopped reading) is closed rather than waited for: the loop never
// blocks on a watcher, and a watcher never sees a gap it cannot detect (`seq`).
void Daemon::Emit(json event) {
  event["seq"] = ++events_;
  event["time_ns"] = std::chrono::duration_cast<std::chrono::nanoseconds>(
                         std::chrono::system_clock::now().time_since_epoch())
                         .count();
  std::string line;
  std::vector<int> behind;
  for (const auto& [fd, client] : clients_) {
    if (!client.watching) continue;
    if (line.empty()) line = JsonText(event) + "\n";
    if (::send(fd, line.data(), line.size(), MSG_NOSIGNAL | MSG_DONTWAIT) !=
        static_cast<ssize_t>(line.size())) {
      behind.push_back(fd);
    }
  }
  for (int fd : behind) {
    spdlog::warn("control socket: a watcher did not keep up with the events; closed");
    CloseClient(fd);
  }
}

// The camera's errors and its return, from the capture thread's counters (polled by the timer).
void Daemon::EmitCameraChanges() {
  const CaptureStats stats = capture_->stats();
  if (stats.errors > camera_errors_seen_) {
    camera_errors_seen_ = stats.errors;
    camera_failing_ = true;
    Emit({{"event", "camera_error"}, {"errors", stats.errors}, {"error", stats.last_error}});
  } else if (camera_failing_ && stats.frames > camera_frames_seen_) {
    camera_failing_ = false;
    Emit({{"event", "camera_back"}, {"frames", stats.frames}});
  }
  camera_frames_seen_ = stats.frames;
  if (stats.end_of_stream && !camera_ended_) {
    camera_ended_ = true;
    Emit({{"event", "camera_ended"}, {"frames", stats.frames}});
  }
}

void Daemon::LogHookStart(const HookStart& start) {
  if (start.message.empty()) return;  // No hook configured.
  if (start.started) {
    spdlog::info("{}", start.message);
  } else {
    spdlog::warn("{}", start.message);
  }
}

void Daemon::OnHooksEnded() {
  for (const HookEnd& end : hooks_.Reap()) {
    if (end.timed_out) {
      spdlog::warn("hook {} (pid {}) killed at its {} s limit ({})", end.name, end.pid,
                   config_.hooks.timeout_s, end.how);
    } else if (!end.ok) {
      spdlog::warn("hook {} (pid {}) failed: {} after {:.2f} s", end.name, end.pid, end.how,
                   end.seconds);
    } else {
      spdlog::info("hook {} (pid {}) {} after {:.2f} s", end.name, end.pid, end.how, end.seconds);
    }
    Emit({{"event", "hook"},
          {"hook", end.name},
          {"ok", end.ok},
          {"timed_out", end.timed_out},
          {"how", end.how},
          {"seconds", end.seconds}});
  }
}

json Daemon::OnOdom(const std::string& line) {
  std::string error;
  const std::optional<OdometrySample> sample = ParseOdometryLine(OdomArguments(line), &error);
  if (!sample) return {{"ok", false}, {"error", "odom: " + error}};
  odometry_.Add(*sample);
  return {{"ok", true}};
}

json Daemon::Answer(const std::string& request) {
  switch (ParseControlCommand(request)) {
    case ControlCommand::kTrigger: {
      json reply;
      OnTrigger("control socket", &reply);
      return reply;
    }
    case ControlCommand::kStatus:
      return Status();
    case ControlCommand::kPing:
      return {{"ok", true}};
    case ControlCommand::kOdom:
      return OnOdom(request);
    case ControlCommand::kWalkStart:
      return OnWalkStart("control socket");
    case ControlCommand::kWalkStop:
      return OnWalkStop("control socket", "operator");
    case ControlCommand::kWatch:  // Served by OnClient (the connection stays).
    case ControlCommand::kUnknown:
      break;
  }
  return {{"ok", false}, {"error", UnknownControlCommandError(request)}};
}

json Daemon::Status() {
  const CaptureStats stats = capture_->stats();
  return {{"ok", true},
          {"state", Name(state_)},
          {"captures", captures_},
          {"last_trigger", last_trigger_},
          {"triggers",
           [this] {
             json list = json::array();
             for (const auto& t : triggers_) list.push_back(t->Describe());
             list.push_back("control socket " + config_.control_socket.string());
             return list;
           }()},
          {"meshes", succeeded_},
          {"camera",
           {{"source", capture_->Describe()},
            {"frames", stats.frames},
            {"frame_rate_hz", stats.frame_rate_hz},
            {"dropped", stats.dropped},
            {"errors", stats.errors},
            {"end_of_stream", stats.end_of_stream},
            {"last_error", stats.last_error}}},
          {"gate",
           {{"tracks", session_.last_decision().tracks},
            {"parallax_deg", session_.last_decision().median_parallax_deg},
            {"essential_inliers", session_.last_decision().essential_inliers},
            {"homography_inliers", session_.last_decision().homography_inliers},
            {"b_tries", session_.tries().size()},
            {"reason", session_.last_decision().reason}}},
          {"scale",
           {{"source", ScaleSourceName(config_.scale.source)}, {"odometry", odometry_.Describe()}}},
          {"walk",
           [this] {
             const WalkStatus w = walk_->status();
             return json{{"walking", w.walking},
                         {"finishing", w.finishing},
                         {"walk", w.walking ? w.walk : walks_},
                         {"frames", w.frames},
                         {"keyframes", w.keyframes},
                         {"registered", w.registered},
                         {"segment", w.segment},
                         {"parallax_deg", w.parallax_deg},
                         {"target_deg", config_.walk.gate.parallax_deg},
                         {"seconds", w.seconds},
                         {"last_result", last_walk_}};
           }()},
          {"spool", spool_.dir().string()},
          {"last_result", last_result_}};
}

}  // namespace

int RunDaemon(const DaemonConfig& config) {
  BouguetCamera camera;
  try {
    camera = LoadCalibration(config.calibration);
  } catch (const CalibrationError& e) {
    spdlog::critical("{}", e.what());
    return kExitConfig;
  }
  if (camera.width <= 0) {
    spdlog::critical("{}: image_size is required by the daemon", config.calibration.string());
    return kExitConfig;
  }
  if (std::string problem = config.gate.Check(); !problem.empty()) {
    spdlog::critical("config: keyframes.{}", problem);
    return kExitConfig;
  }
  // The event loop's top: construction too (the undistortion maps are made there, and OpenCV
  // throws cv::Exception on what it cannot allocate).
  try {
    Daemon daemon(config, camera);
    return daemon.Run();
  } catch (const std::exception& e) {
    spdlog::critical("internal error: {}", e.what());
    return kExitSoftware;
  } catch (...) {
    spdlog::critical("internal error: unknown exception");
    return kExitSoftware;
  }
}

}  // namespace mm
