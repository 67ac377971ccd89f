#pragma once
// WalkTracker: a walk's frames in, keyframes into the map (map/walk_map.h). The first frame is
// a keyframe; after it, the keyframe gate (recon/keyframe_gate.h) tracks the last keyframe's
// corners into each frame, and a frame becomes the next keyframe when the rotation-compensated
// parallax against the last one passes the gate's threshold, or when the view leaves the last
// one's (the tracks are lost: the map then decides whether it still registers). The daemon's
// walk and `monomesh eval --walk` go through this one policy.
//
// Thread-safety: one instance per thread.

#include <Eigen/Core>
#include <opencv2/core.hpp>
#include <optional>

#include "map/walk_map.h"
#include "recon/keyframe_gate.h"

namespace mm {

struct WalkTrackerOptions {
  WalkOptions walk;
  KeyframeGateOptions gate;
  [[nodiscard]] std::string Check() const;
};

/// One frame through the tracker.
struct WalkFrameStep {
  GateDecision decision;                     ///< The gate's (empty for the first frame).
  std::optional<WalkKeyframeSummary> added;  ///< Set when the frame became a keyframe.
};

class WalkTracker {
 public:
  /// `K`: the undistorted frames' intrinsics.
  WalkTracker(const Eigen::Matrix3d& K, const WalkTrackerOptions& options);

  /// One undistorted 8-bit gray frame at `timestamp_s`.
  WalkFrameStep AddFrame(const cv::Mat& gray, double timestamp_s);

  [[nodiscard]] const WalkMap& map() const { return map_; }
  /// The parallax (deg) of the newest frame against the last keyframe (0 before the second).
  [[nodiscard]] double parallax_deg() const { return last_decision_.median_parallax_deg; }
  [[nodiscard]] const GateDecision& last_decision() const { return last_decision_; }

 private:
  WalkMap map_;
  KeyframeGate gate_;
  bool started_ = false;
  GateDecision last_decision_;
};

}  // namespace mm
