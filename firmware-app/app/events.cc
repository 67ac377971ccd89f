// The daemon's events (docs/control.md, `monomesh ctl watch`): the watchers, and the events
// that are not a capture's or a walk's own: the camera's errors and return, the hooks' ends.

#include "app/daemon_loop.h"

#include <spdlog/spdlog.h>
#include <sys/socket.h>

#include <algorithm>
#include <chrono>
#include <vector>

#include "entry/json_text.h"

namespace mm::daemon_detail {

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

}  // namespace mm::daemon_detail
