#pragma once
// The walk's thread (walk mode, docs/walk.md): frames from the event loop in, keyframes into
// the map, and at the end the walk's spool entry. While walking, the loop offers the newest
// frame whenever the thread is free (frames that arrive meanwhile are skipped, as in the
// capture's gate); the thread undistorts it and runs it through the WalkTracker (the gate, and
// for a keyframe the registration, SIFT to local BA). A keyframe's undistorted image is kept
// JPEG-encoded (the entry's keyframe images and the mesh's textures). Stop (the operator, the
// timeout, a lost camera, the daemon's end) or the keyframe limit ends the walk: the thread
// builds the map mesh, encodes the entry and commits it to the spool, whole or not at all, and
// reports the outcome through `done_fd` like every step.
//
// Thread-safety: every public method from one thread (the event loop).

#include <condition_variable>
#include <cstdint>
#include <deque>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "app/config.h"
#include "app/pair_job.h"
#include "calib/undistort.h"
#include "capture/frame.h"
#include "entry/report.h"
#include "map/walk_tracker.h"
#include "spool/spool.h"

namespace mm {

/// Where a walk stands (for `ctl status`).
struct WalkStatus {
  bool walking = false;    ///< Between Start and the end of the entry.
  bool finishing = false;  ///< Stopped; the entry is being made.
  uint64_t walk = 0;
  uint64_t frames = 0;  ///< Frames the walk looked at.
  int keyframes = 0;
  int registered = 0;  ///< Registered to the map they joined (not new segments after a loss).
  int segment = 0;     ///< The current segment.
  int segments = 0;    ///< Segments in the map now (merged ones count once).
  int relocalizations = 0;
  int merges = 0;  ///< Segments merged into another.
  int loop_closures = 0;
  int lost_keyframes = 0;       ///< Keyframes neither registered nor relocalised.
  uint64_t tracked_frames = 0;  ///< Frames with a pose from the tracked map points.
  bool tracking = false;        ///< The newest frame had one.
  double parallax_deg = 0.0;    ///< The newest frame's against the last keyframe.
  double seconds = 0.0;         ///< Since the start.
};

/// What ended a walk.
struct WalkOutcome {
  uint64_t walk = 0;
  bool ok = false;  ///< The entry was committed.
  std::string entry;
  std::string error;
  std::string stop_reason;
  int keyframes = 0;
  int registered = 0;
  int segments = 0;
  double seconds = 0.0;  ///< Making the entry.
};

/// The robot's odometry at two keyframes' times (the daemon's `odom` stream), or why not.
using OdometryLookup =
    std::function<PairScaleInputs(const KeyframeInfo& first, const KeyframeInfo& last)>;

class WalkThread {
 public:
  /// `undistorter` and `spool` outlive the thread; `done_fd` is an eventfd. `odometry` serves
  /// the odometry and auto scale sources ([scale]); empty: none.
  WalkThread(const DaemonConfig& config, const Undistorter& undistorter, Spool* spool, int done_fd,
             OdometryLookup odometry = {});
  ~WalkThread();  // A walk still open is abandoned (nothing written).
  WalkThread(const WalkThread&) = delete;
  WalkThread& operator=(const WalkThread&) = delete;

  /// Starts walk `walk` with `first` as its first keyframe. Requires no walk open.
  void Start(uint64_t walk, FramePtr first);
  /// Offers the newest frame; ignored while the thread is busy with one, or the walk stopping.
  /// Returns whether it was taken.
  bool Offer(FramePtr frame);
  /// Ends the walk (the frame in hand first); the outcome follows through done_fd.
  void Stop(const std::string& reason);
  /// Blocks until the walk's entry is written (or the walk abandoned), e.g. at the daemon's end.
  void WaitFinished();

  [[nodiscard]] WalkStatus status() const;
  /// The keyframes added since the last call (for the loop's events), in order.
  std::vector<WalkKeyframeSummary> TakeKeyframes();
  std::optional<WalkOutcome> TakeOutcome();
  /// Set when an exception reached the thread's top: the daemon exits 70.
  std::optional<std::string> fatal_error() const;

 private:
  void Run();
  void RunGuarded();
  void AddFrame(const FramePtr& frame);
  WalkOutcome Finish();
  void Signal() const;

  const DaemonConfig& config_;
  const Undistorter& undistorter_;
  Spool* spool_;
  int done_fd_;
  OdometryLookup odometry_;

  // The walk itself: touched only by the thread while open (after Start hands it over).
  std::unique_ptr<WalkTracker> tracker_;
  std::vector<std::string> jpegs_;
  std::vector<KeyframeInfo> infos_;
  std::vector<WalkKeyframeSummary> summaries_;
  std::chrono::steady_clock::time_point started_;

  mutable std::mutex mutex_;
  std::condition_variable cv_;
  bool quit_ = false;                       // Guarded by mutex_.
  FramePtr posted_;                         // Guarded by mutex_.
  bool running_ = false;                    // A frame in hand; guarded by mutex_.
  std::optional<std::string> stop_;         // The stop reason; guarded by mutex_.
  WalkStatus status_;                       // Guarded by mutex_.
  std::vector<WalkKeyframeSummary> added_;  // Guarded by mutex_.
  std::deque<WalkOutcome> outcomes_;        // Guarded by mutex_.
  std::optional<std::string> fatal_error_;  // Guarded by mutex_.
  std::thread thread_;                      // Last: starts after the members it uses.
};

}  // namespace mm
