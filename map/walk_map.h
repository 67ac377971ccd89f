#pragma once
// WalkMap: many keyframes registered into one map with one scale, online (a walk, docs/walk.md).
//   The first two keyframes of a segment: the two-view stage (recon/two_view.h) fixes the
//   segment's frame (its first keyframe) and its scale (their baseline = 1).
//   Each later keyframe: SIFT matched against the newest keyframes, 2-D/3-D matches to their
//   points, the absolute pose by RANSAC over SQPnP (Terzakis & Lourakis 2020, OpenCV's
//   solvePnPRansac) and LM on the inliers; the window's other points found by projection;
//   new points triangulated (DLT, checked for cheirality, reprojection and angle); a local
//   bundle adjustment over a sliding window (map/local_bundle.h: the window's two oldest
//   keyframes fixed, which fixes the gauge and the scale).
//   A keyframe that cannot be registered starts a new segment: a wrong pose is never folded
//   into the map.
//
// Thread-safety: one instance per thread; deterministic for the same input and seed.
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "map/local_bundle.h"
#include "recon/features.h"
#include "recon/two_view.h"

namespace mm {

struct WalkOptions {
  /// SIFT on the image resized by 0.75 first (1.5x the pixels from the doubled first octave
  /// instead of 4x): on the TUM keyframes the same ATE as at full size, 40 % less CPU per
  /// keyframe (docs/walk.md).
  SiftOptions sift = [] {
    SiftOptions s;
    s.resize_factor = 0.75;
    return s;
  }();
  MatchOptions match;
  TwoViewOptions two_view;
  /// Newest keyframes the new one is matched against (descriptors, all against all); the
  /// older window keyframes' points are found by projection (search_radius_px).
  int match_keyframes = 1;
  /// After the pose: the window's map points not yet matched are projected into the new
  /// keyframe and take the keypoint within this radius whose descriptor is nearest to the
  /// point's newest observation, if it passes match.ratio against the runner-up there
  /// (ORB-SLAM's local map search, Mur-Artal et al. 2015, sec. V-D).
  double search_radius_px = 3.0;
  double pnp_reprojection_px = 2.0;  ///< RANSAC inlier threshold of the absolute pose.
  int pnp_iterations = 1000;
  int min_pnp_inliers = 30;                  ///< Fewer: the keyframe starts a new segment.
  double max_reprojection_px = 2.0;          ///< New points and observations after the BA.
  double min_triangulation_angle_deg = 1.0;  ///< New points seen under a smaller angle: dropped.
  int window = 6;  ///< Keyframes the local BA adjusts (two of them fixed).
  LocalBundleOptions bundle;
  unsigned seed = 0;  ///< Seeds the two-view RANSACs (OpenCV's PnP RANSAC has a fixed seed).
  [[nodiscard]] std::string Check() const;
};

/// What happened to one keyframe.
struct WalkKeyframeSummary {
  int index = 0;              ///< In the order added.
  int segment = 0;            ///< Its segment (0, 1, ...); a new one after a lost registration.
  bool registered = false;    ///< Has a pose in its segment (a segment's first keyframe: true).
  std::string failure;        ///< Why it was not registered to the previous keyframes.
  int matches = 0;            ///< Descriptor matches to the newest keyframes.
  int matches_3d = 0;         ///< Of them, with a map point (PnP input).
  int projected_matches = 0;  ///< Map points found by projection after the pose.
  int pnp_inliers = 0;
  int new_points = 0;          ///< Triangulated with this keyframe.
  double bundle_rms_px = 0.0;  ///< The local BA's final RMS (0 when it did not run).
  double time_s = 0.0;         ///< CPU-bound wall time of AddKeyframe (SIFT included).
  double sift_s = 0.0;         ///< Of it: SIFT,
  double matching_s = 0.0;     ///< descriptor matching,
  double pose_s = 0.0;         ///< the pose (two-view or PnP) and the new points,
  double bundle_s = 0.0;       ///< the local bundle adjustment.
};

struct WalkKeyframe {
  double timestamp_s = 0.0;
  int segment = 0;
  bool registered = false;
  Eigen::Isometry3d cam_from_segment = Eigen::Isometry3d::Identity();
  /// SIFT keypoints and descriptors, released (empty) once the keyframe is older than the
  /// window and the matched keyframes: they are not read again.
  Features features;
  /// Each keypoint's pixel (full-size image), kept for the keyframe's life (bundle adjustment,
  /// the entry's observations): 8 bytes a keypoint instead of the keypoint and descriptor's 540.
  std::vector<Eigen::Vector2f> keypoint_pixels;
  std::vector<int> point_of_keypoint;  ///< Map point per keypoint, -1 when none.
};

struct WalkPoint {
  Eigen::Vector3d position_in_segment = Eigen::Vector3d::Zero();
  int segment = 0;
  struct Observation {
    int keyframe = 0;
    int keypoint = 0;
  };
  std::vector<Observation> observations;
  bool valid = true;
};

class WalkMap {
 public:
  /// `K`: the undistorted camera's intrinsics.
  WalkMap(const Eigen::Matrix3d& K, const WalkOptions& options);

  /// Adds a keyframe (8-bit gray, undistorted) and registers it.
  WalkKeyframeSummary AddKeyframe(const cv::Mat& gray, double timestamp_s);

  [[nodiscard]] const std::vector<WalkKeyframe>& keyframes() const { return keyframes_; }
  [[nodiscard]] const std::vector<WalkPoint>& points() const { return points_; }
  [[nodiscard]] int segments() const { return segment_ + 1; }

 private:
  // Indices of the current segment's keyframes, oldest first.
  [[nodiscard]] std::vector<int> SegmentKeyframes() const;
  void StartSegment(int keyframe);
  bool Initialize(int keyframe, WalkKeyframeSummary* summary);
  bool Register(int keyframe, WalkKeyframeSummary* summary);
  int TriangulateWith(int keyframe, int other, const std::vector<Match>& matches);
  int SearchByProjection(int keyframe);
  void AdjustWindow(WalkKeyframeSummary* summary);
  [[nodiscard]] Eigen::Vector2d Pixel(int keyframe, int keypoint) const;

  Eigen::Matrix3d K_;
  WalkOptions options_;
  std::vector<WalkKeyframe> keyframes_;
  std::vector<WalkPoint> points_;
  int segment_ = 0;
  int segment_start_ = 0;
};

}  // namespace mm
