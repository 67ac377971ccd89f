#pragma once
// WalkTracker: a walk's frames in, keyframes into the map (map/walk_map.h). Every frame is
// tracked against the map (PTAM's and ORB-SLAM's tracking thread, one thread here): the map
// points the last keyframe sees are followed frame to frame by pyramidal Lucas-Kanade, and the
// frame's pose comes from them by RANSAC over SQPnP and LM on the inliers (motion-only). A
// frame becomes the next keyframe when
//   - the tracking weakens: it follows fewer than `min_tracked_share` of the map points the
//     last keyframe started with, or fewer than `min_tracked_points` (then its own pose is the
//     prior the keyframe's registration starts from), or
//   - the parallax passes the gate's threshold: the median angle at the tracked points between
//     the rays from the last keyframe and from the frame (rotation does not count), or
//   - while not tracking (a segment's first keyframe): the keyframe gate (recon/keyframe_gate.h)
//     says so, by its rotation-compensated parallax or its tracks being lost;
//   - while the map is lost (the last keyframe neither registered nor relocalised): every
//     `lost_retry_frames`-th frame, each a relocalisation attempt.
// The daemon's walk and `monomesh eval --walk` go through this one policy.
//
// Thread-safety: one instance per thread.

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <vector>

#include "map/walk_map.h"
#include "recon/keyframe_gate.h"

namespace mm {

struct WalkTrackerOptions {
  WalkOptions walk;
  KeyframeGateOptions gate;
  /// A keyframe once the frame tracks fewer than this share of the map points tracked from
  /// the last keyframe (ORB-SLAM inserts at 90 % with its mapping in a thread of its own;
  /// here the keyframe costs the tracking thread, so later).
  double min_tracked_share = 0.5;
  int min_tracked_points = 40;   ///< Fewer tracked map points (or no pose): a keyframe now.
  int max_tracked_points = 400;  ///< Map points followed from a keyframe (spread over a grid).
  double track_reprojection_px = 2.0;  ///< Motion-only PnP inlier threshold.
  int track_ransac_iterations = 40;
  int klt_window_px = 21;
  int klt_levels = 3;
  int lost_retry_frames = 3;  ///< While lost: every n-th frame a relocalisation keyframe.
  [[nodiscard]] std::string Check() const;
};

/// One frame through the tracker.
struct WalkFrameStep {
  GateDecision decision;                     ///< The gate's (empty for the first frame).
  std::optional<WalkKeyframeSummary> added;  ///< Set when the frame became a keyframe.
  /// Why the frame became a keyframe: "first", "parallax", "gate lost track", "tracking weak",
  /// "tracking lost", "relocalisation" (empty: not a keyframe).
  std::string keyframe_reason;
  bool tracked = false;  ///< The frame's pose came from the tracked map points.
  int tracked_points = 0;
  int segment = -1;  ///< The pose's segment.
  Eigen::Isometry3d cam_from_segment = Eigen::Isometry3d::Identity();
};

class WalkTracker {
 public:
  /// `K`: the undistorted frames' intrinsics.
  WalkTracker(const Eigen::Matrix3d& K, const WalkTrackerOptions& options);

  /// One undistorted 8-bit gray frame at `timestamp_s`.
  WalkFrameStep AddFrame(const cv::Mat& gray, double timestamp_s);

  [[nodiscard]] const WalkMap& map() const { return map_; }
  /// The map, to refine once the walk is over (map/walk_refine.h).
  WalkMap& mutable_map() { return map_; }
  /// The walk is over: the map's background work is finished and applied (WalkMap::Finish).
  void Finish() { map_.Finish(); }
  /// The parallax (deg) of the newest frame against the last keyframe (0 before the second).
  [[nodiscard]] double parallax_deg() const { return last_decision_.median_parallax_deg; }
  [[nodiscard]] const GateDecision& last_decision() const { return last_decision_; }
  [[nodiscard]] int tracked_frames() const { return tracked_frames_; }

 private:
  // Follows the map points from the previous frame into `gray` and fits the frame's pose.
  void Track(const cv::Mat& gray, WalkFrameStep* step);
  // Median angle at the tracked points between the rays from the last keyframe's centre and
  // from the centre of `cam_from_segment`.
  [[nodiscard]] double MedianTriangulationAngleDeg(const Eigen::Isometry3d& cam_from_segment) const;
  // Starts tracking from the newest keyframe (its map points), `gray` its image.
  void Seed(const cv::Mat& gray);

  Eigen::Matrix3d K_;
  WalkTrackerOptions options_;
  WalkMap map_;
  KeyframeGate gate_;
  bool started_ = false;
  GateDecision last_decision_;
  cv::Mat previous_;
  std::vector<cv::Point2f> track_pixels_;  // In the previous frame.
  std::vector<int> track_points_;          // Map point of each track.
  int seeded_points_ = 0;
  Eigen::Vector3d keyframe_centre_ = Eigen::Vector3d::Zero();  // Of the last keyframe.
  int segment_ = -1;
  Eigen::Isometry3d cam_from_segment_ = Eigen::Isometry3d::Identity();
  int frames_since_keyframe_ = 0;
  int tracked_frames_ = 0;
};

}  // namespace mm
