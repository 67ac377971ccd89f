#pragma once
// The keyframe gate's thread: undistorts each frame a capture tracks and runs the gate on it
// (CaptureSession::Track: KLT and the two-view probe, tens of milliseconds on a board) off the
// daemon's event loop, so the control socket, triggers and the watchdog are served meanwhile.
// One frame at a time: the loop posts a frame, the thread signals `done_fd` when its decision
// is ready, the loop takes it and applies the capture's policy (CaptureSession::OnTracked)
// before posting the next. While a frame is posted the loop must not call the session's
// methods that touch the gate (Start, OnResult, Tracks); WaitIdle bounds that wait to one
// frame's tracking.
//
// Thread-safety: Post, Take, WaitIdle and busy from one thread (the event loop).

#include <condition_variable>
#include <cstdint>
#include <mutex>
#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <thread>

#include "calib/undistort.h"
#include "capture/frame.h"
#include "session/capture_session.h"

namespace mm {

/// One frame through the gate.
struct TrackedFrame {
  uint64_t capture_id = 0;  ///< The capture the frame was posted for.
  FramePtr frame;
  cv::Mat undistorted;  ///< What the gate saw (colour, as the reconstruction wants it).
  GateDecision decision;
  std::string error;  ///< Set when the frame could not be undistorted (no decision).
};

class GateThread {
 public:
  /// `undistorter` and `session` outlive the thread; `done_fd` is an eventfd.
  GateThread(const Undistorter& undistorter, CaptureSession* session, int done_fd);
  ~GateThread();
  GateThread(const GateThread&) = delete;
  GateThread& operator=(const GateThread&) = delete;

  /// A frame is posted and its result not yet taken.
  [[nodiscard]] bool busy() const;
  /// Tracks `frame` for capture `capture_id`. Requires !busy().
  void Post(uint64_t capture_id, FramePtr frame);
  /// The posted frame's result once it is ready (then the thread is free for the next).
  std::optional<TrackedFrame> Take();
  /// Blocks until the posted frame, if any, has been tracked; its result stays for Take.
  void WaitIdle();

 private:
  void Run();

  const Undistorter& undistorter_;
  CaptureSession* session_;
  int done_fd_;
  mutable std::mutex mutex_;
  std::condition_variable cv_;
  bool stop_ = false;                   // Guarded by mutex_.
  std::optional<TrackedFrame> posted_;  // Not yet started; guarded by mutex_.
  bool running_ = false;                // A frame is being tracked; guarded by mutex_.
  std::optional<TrackedFrame> done_;    // Guarded by mutex_.
  std::thread thread_;                  // Last: starts after the members it uses.
};

}  // namespace mm
