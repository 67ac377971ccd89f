// Signals and the daemon's stop: the signalfd's signals, and after the loop the shutdown (a
// capture being reconstructed or a walk finishes its entry first; a capture still tracking is
// abandoned), the stopped event and the control socket removed.

#include "app/daemon_loop.h"

#include <signal.h>
#include <spdlog/spdlog.h>
#include <sys/signalfd.h>
#include <sys/stat.h>
#include <systemd/sd-daemon.h>
#include <unistd.h>

#include <utility>

namespace mm::daemon_detail {

// SIGTERM/SIGINT stop the loop; SIGCHLD is a hook's end; SIGHUP is ignored. (SIGUSR1 is a
// trigger, read by its SignalTrigger.)
void Daemon::OnSignals() {
  signalfd_siginfo info{};
  while (::read(signal_fd_.get(), &info, sizeof(info)) == sizeof(info)) {
    if (info.ssi_signo == SIGCHLD) {
      OnHooksEnded();
    } else if (info.ssi_signo == SIGHUP) {
      spdlog::info("SIGHUP ignored (restart the service to reload the config)");
    } else {
      spdlog::info("signal {}: stopping", info.ssi_signo);
      stop_ = true;
    }
  }
}

void Daemon::Shutdown() {
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

}  // namespace mm::daemon_detail
