#pragma once
// The daemon's event loop (monomeshd, docs/architecture.md): the Daemon class, private to the
// daemon's files. Its state lives on the loop's thread; its methods are defined by concern:
//
//   daemon.cc          RunDaemon, start-up (Start), the main loop (Run), the timer, SetState
//   capture_state.cc   press to entry: trigger, keyframe A, the gate's frames, keyframe B to
//                      the worker, its result (a later B, the entry, or the failure)
//   walk_control.cc    walk mode's start, stop and results (the walk runs in WalkThread)
//   control_clients.cc the control socket's connections: accept, read a line, reply, close
//   control_verbs.cc   the protocol's verbs (docs/control.md): trigger, status, ping, odom,
//                      walk start|stop
//   events.cc          watchers (`watch`) and the events they get; camera and hook events
//   shutdown.cc        signals, and the stop (a capture or walk in flight finished first)
//
// The threads it owns are in their own files: worker.h (the reconstruction), gate_thread.h,
// walk_thread.h; the odometry they share in shared_odometry.h.

#include <sys/types.h>

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "app/config.h"
#include "app/control_protocol.h"
#include "app/gate_thread.h"
#include "app/hooks.h"
#include "app/shared_odometry.h"
#include "app/walk_thread.h"
#include "app/worker.h"
#include "base/unique_fd.h"
#include "calib/undistort.h"
#include "capture/capture_thread.h"
#include "capture/frame.h"
#include "capture/trigger.h"
#include "session/capture_session.h"
#include "session/recent_frames.h"
#include "spool/spool.h"

namespace mm::daemon_detail {

using json = nlohmann::json;

// Exit codes (sysexits.h; docs/exit_codes.md is the table).
constexpr int kExitUnavailable = 69;  // EX_UNAVAILABLE: a device or the socket is not there yet.
constexpr int kExitSoftware = 70;     // EX_SOFTWARE: an internal error (a bug).
constexpr int kExitConfig = 78;       // EX_CONFIG: restarting will not help.

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

inline const char* Name(State s) {
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
  // daemon.cc
  /// Start-up: spool recovery, eventfds, signals, camera, control socket, triggers, the
  /// threads; READY=1. Returns 0, or the exit code when the daemon cannot start.
  int Start();
  void OnTimer();
  void SetState(State s);
  void AddFd(int fd);
  Trigger* FindTrigger(int fd) const;

  // capture_state.cc
  void OnTrigger(const char* origin, json* reply);
  void OnTriggerEvent(Trigger* trigger, const TriggerEvent& event);
  void OnFrame();
  void OnGateDone();
  void ApplyGate(const TrackedFrame& tracked);
  void SettleGate();
  void OnJobDone();
  void EndCapture(const std::string& error);
  static double NowSeconds();                          // The session's clock (steady).
  static double FrameTimeSeconds(const Frame& frame);  // Its capture time (CLOCK_MONOTONIC).
  void KeepRecentFrame();  // The newest frame into recent_frames_ (gray, as captured).

  // walk_control.cc
  json OnWalkStart(const char* origin);
  json OnWalkStop(const char* origin, const std::string& reason);
  void OnWalkDone();
  json WalkStatusJson(const WalkStatus& w) const;  // `status`'s walk and the walk_frame event.

  // control_clients.cc
  void OnAccept();
  void PauseAccept();
  void OnClient(int fd);
  void ReplyAndClose(int fd, const json& reply);
  void CloseClient(int fd);

  // control_verbs.cc
  json Answer(const std::string& request);
  json OnOdom(const std::string& line);
  json Status();

  // events.cc
  void OnWatch(int fd);
  void Emit(json event);
  void EmitCameraChanges();
  static void LogHookStart(const HookStart& start);
  void OnHooksEnded();

  // shutdown.cc
  void OnSignals();  // The signalfd is readable.
  /// After the loop: STOPPING=1, the capture or walk in flight finished, the socket removed.
  void Shutdown();
  void FinishOnStop();

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
  std::chrono::steady_clock::time_point last_walk_event_;
  uint64_t walk_frames_seen_ = 0;    // WalkStatus::frames at the last walk_frame event.
  uint64_t camera_errors_seen_ = 0;  // CaptureStats::errors at the last camera event.
  uint64_t camera_frames_seen_ = 0;
  bool camera_failing_ = false;  // An error since the last frame.
  bool camera_ended_ = false;
  bool stop_ = false;
  bool stopping_ = false;  // Set once the loop has ended: results end captures, start nothing.
};

}  // namespace mm::daemon_detail
