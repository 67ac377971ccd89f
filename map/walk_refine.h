#pragma once
// The walk's refinement once it ends: its keyframe poses from tracks built as an incremental
// SfM builds them (Schonberger & Frahm 2016, COLMAP), not from the walk's own. SIFT on each
// keyframe; the pairs of keyframes that look at the same part of the scene matched and
// verified by a fundamental matrix (RANSAC, H&Z alg. 11.4); the verified matches joined into
// tracks (union-find); each track triangulated from the widest of its pairs under the walk's
// poses that most of its observations agree with; then a bundle adjustment of all poses and
// points. These tracks do not come from the walk's structure, so they can undo what its
// frame-to-frame tracks accumulated (docs/walk.md: its scale drift).
//
// Thread-safety: pure functions, reentrant; RefineSegment changes only the map it is given.
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "map/local_bundle.h"
#include "map/walk_mesh.h"
#include "recon/epipolar.h"
#include "recon/features.h"
#include "recon/matcher.h"

namespace mm {

class WalkMap;

struct TrackRefineOptions {
  /// The walk's own SIFT (docs/walk.md), at most 1500 features a keyframe (the kitchen's have
  /// 700-1400; a rendered corridor's 4000 cost 1.6x the CPU for the same poses); at full size
  /// or with more features the tracks are longer but the poses no better on the kitchen walk.
  SiftOptions sift = [] {
    SiftOptions s;
    s.resize_factor = 0.75;
    s.max_features = 1500;
    return s;
  }();
  MatchOptions match;
  RansacOptions verify = [] {
    RansacOptions r;
    r.threshold_px = 2.0;
    r.max_iterations = 2000;
    return r;
  }();
  /// A pair is matched when the point each keyframe looks at (its centre plus its median
  /// scene depth along its axis) is in the other's image and their axes are within this
  /// angle; keyframes next to each other always are.
  double max_axis_angle_deg = 60.0;
  int min_pair_inliers = 15;           ///< Fewer verified matches: the pair adds no track.
  double min_angle_deg = 1.5;          ///< A track's widest pair must see it under this at least.
  int triangulation_tries = 5;         ///< Widest pairs tried per track.
  int max_track_length = 40;           ///< Longer: a chain of wrong matches, not a point.
  double max_reprojection_px = 4.0;    ///< Under the walk's poses, before the adjustment.
  double final_reprojection_px = 2.0;  ///< After it; then adjusted once more.
  LocalBundleOptions bundle = [] {
    LocalBundleOptions b;
    b.max_iterations = 30;
    return b;
  }();
  /// Larger segments are not refined (RefineSegment): the pairs grow with the keyframes and
  /// their CPU with them (6.3 s for the kitchen's 49 keyframes, 40 s for 105 round a
  /// corridor and a half on this machine; docs/walk.md).
  int max_keyframes = 100;
  [[nodiscard]] std::string Check() const;
};

struct TrackRefineSummary {
  bool ran = false;
  std::string skipped;  ///< Why it did not run (RefineSegment), empty otherwise.
  int keyframes = 0;
  int pairs = 0;           ///< Pairs matched.
  int verified_pairs = 0;  ///< Of them, with a fundamental matrix of min_pair_inliers.
  int tracks = 0;          ///< Components of two or more keyframes.
  int points = 0;          ///< Triangulated and kept.
  int observations = 0;
  LocalBundleSummary bundle;  ///< The second adjustment.
  double cpu_s = 0.0;         ///< Thread CPU time.
};

struct TrackRefineResult {
  std::vector<Eigen::Isometry3d> cam_from_world;      ///< Per keyframe, refined.
  std::vector<Eigen::Vector3d> kept_points_in_world;  ///< The `kept` points, adjusted.
  TrackRefineSummary summary;
};

/// One keyframe's keypoint in a track.
struct TrackObservation {
  int keyframe = 0;
  Eigen::Vector2d pixel = Eigen::Vector2d::Zero();
};
using Track = std::vector<TrackObservation>;

/// The tracks of 8-bit gray images (undistorted, intrinsics `k`): SIFT, the pairs chosen under
/// `cam_from_world` and `scene_depth` (per keyframe, in the poses' units; <= 0: unknown, then
/// it pairs only with its neighbours) matched and verified, the matches joined. Each track
/// has two or more keyframes; it may see one twice (conflicting matches). Fills the pair and
/// track counts of `summary`.
std::vector<Track> BuildTracks(const Eigen::Matrix3d& k, const std::vector<cv::Mat>& grays,
                               const std::vector<Eigen::Isometry3d>& cam_from_world,
                               const std::vector<double>& scene_depth,
                               const TrackRefineOptions& options, TrackRefineSummary* summary);

/// Refines `cam_from_world` with `tracks` (keyframe: index into it): each track triangulated
/// and filtered, then two bundle adjustments, the first two keyframes fixed (gauge and scale).
/// `kept` (optional): points adjusted with the tracks as they are (the walk's own; their
/// observations' `pose` indexes cam_from_world); their positions come back in
/// kept_points_in_world.
TrackRefineResult RefinePosesWithTracks(const Eigen::Matrix3d& k, const std::vector<Track>& tracks,
                                        const std::vector<Eigen::Isometry3d>& cam_from_world,
                                        const TrackRefineOptions& options,
                                        const LocalBundleProblem* kept = nullptr);

/// BuildTracks and RefinePosesWithTracks on the registered keyframes of `segment` (images from
/// `image_of`, colour or gray) with the segment's own points and observations kept in the
/// adjustment; the map then takes the refined poses and positions (WalkMap::MoveKeyframes).
/// A segment of more than options.max_keyframes is left as it is (summary.skipped says so).
TrackRefineSummary RefineSegment(WalkMap* map, int segment, const Eigen::Matrix3d& k,
                                 const KeyframeImageFn& image_of,
                                 const TrackRefineOptions& options);

}  // namespace mm
