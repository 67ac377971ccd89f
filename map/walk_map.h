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
//   With a pose prior (the frame tracker's pose of the keyframe, map/walk_tracker.h) the local
//   map's points are also projected under it and searched around their projections (ORB-SLAM's
//   tracking of the local map, Mur-Artal et al. 2015, sec. V-D): the PnP's candidates.
//   A keyframe that does not register to the newest keyframes is relocalised: matched against
//   the earlier keyframes most like it by their thumbnails (small blurred images, PTAM's
//   relocaliser, Klein & Murray 2008), then PnP. One that does neither is lost (kept without a
//   pose; a wrong pose is never folded into the map); after `max_lost_keyframes` lost ones in
//   a row the next starts a new segment, which is merged into the older one by a Sim(3) of
//   their shared points (Umeyama 1991) as soon as one of its keyframes relocalises against it.
//
// Thread-safety: one instance per thread; deterministic for the same input and seed.
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <map>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "map/background_bundle.h"
#include "map/local_bundle.h"
#include "map/pose_graph.h"
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
  /// Newest keyframes the new one is matched against (descriptors, all against all) and
  /// triangulates new points with; the older window keyframes' points are found by
  /// projection (search_radius_px). Three: new points also from the wider baselines to the
  /// second and third newest (ORB-SLAM triangulates with its covisible keyframes); on the
  /// hand-held kitchen walk 3 was one segment where 1 split it (docs/walk.md).
  int match_keyframes = 3;
  /// After the pose: the window's map points not yet matched are projected into the new
  /// keyframe and take the keypoint within this radius whose descriptor is nearest to the
  /// point's newest observation, if it passes match.ratio against the runner-up there
  /// (ORB-SLAM's local map search, Mur-Artal et al. 2015, sec. V-D).
  double search_radius_px = 3.0;
  double pnp_reprojection_px = 2.0;  ///< RANSAC inlier threshold of the absolute pose.
  int pnp_iterations = 1000;
  int min_pnp_inliers = 30;  ///< Fewer: not registered (relocalised or lost).
  /// With a pose prior: the local map's points (the keyframes that share the most points
  /// with the newest, `window` of them) projected under the prior each take the keypoint
  /// within this radius whose descriptor is nearest to theirs (ratio test as above).
  double prior_search_radius_px = 12.0;
  /// Bridging: a keyframe whose PnP fails (the view moved on to what the map has few points
  /// of, e.g. frames skipped under load) is registered by the two-view stage against the
  /// newest keyframe (F by RANSAC, E, cheirality), its baseline scaled by the map's depth over
  /// the pair's at the points both have: at least this many, agreeing within 10 % (MAD).
  int min_bridge_points = 8;
  /// Relocalisation: the new keyframe matched against this many earlier keyframes, the most
  /// similar by their thumbnails (normalised cross-correlation of 40x30 blurred images).
  int relocalization_candidates = 4;
  /// Descriptors a keyframe keeps, 8-bit, once it leaves the window: of its map points seen
  /// most often (relocalisation against it and the search by projection read them).
  int kept_descriptors = 256;
  /// Lost keyframes (neither registered nor relocalised) in a row before the next keyframe
  /// starts a new segment.
  int max_lost_keyframes = 4;
  /// Segment merging: while the map has more than one segment, each registered keyframe of
  /// the current one is also relocalised against the others; a merge needs this many shared
  /// points agreeing with the Sim(3) (within 5 % of their depth).
  int min_merge_points = 20;
  /// Loop closure: each registered keyframe is also relocalised against keyframes of its
  /// segment at least this many keyframes older that share no point with its neighbourhood
  /// and look at least as much like it as its neighbours do (0: no loop closure). A loop
  /// needs min_loop_inliers PnP inliers and min_merge_points shared points agreeing with
  /// the Sim(3); the drift is then spread by a Sim(3) pose graph (map/pose_graph.h) and the
  /// segment bundle-adjusted (all its keyframes, the first two fixed; see below).
  int loop_min_gap_keyframes = 10;
  int min_loop_inliers = 50;
  int loop_candidates = 2;
  PoseGraphOptions pose_graph;
  /// After a loop, the bundle adjustment of the whole segment runs on a copy of it in a thread
  /// of its own while keyframes go on being added (ORB-SLAM's global bundle adjustment after
  /// a loop, Mur-Artal & Tardos 2017): at the end of the first keyframe after it finished, the
  /// adjusted poses and points replace theirs, the keyframes added meanwhile keep their pose
  /// relative to the newest adjusted keyframe and the points they made follow their first
  /// observer. >= 0: at the end of exactly that many keyframes after the loop's, waiting for
  /// it if it still runs, so that a run is the same on every machine (the eval's setting).
  int global_bundle_apply_after = -1;
  /// Segments with more keyframes get, after a loop, a bundle adjustment of the windows at
  /// both ends of the loop (in the walk's thread) instead of one of the whole segment (in the
  /// background; its CPU and memory grow with the segment: 2 s for 102 keyframes here).
  int global_bundle_max_keyframes = 150;
  /// ... or more observations (its memory: about 410 bytes each with Ceres's, measured).
  int global_bundle_max_observations = 200000;
  LocalBundleOptions global_bundle = [] {
    LocalBundleOptions b;
    b.max_iterations = 15;
    return b;
  }();
  double max_reprojection_px = 2.0;          ///< New points and observations after the BA.
  double min_triangulation_angle_deg = 1.0;  ///< New points seen under a smaller angle: dropped.
  int window = 6;  ///< Keyframes the local BA adjusts (two of them fixed).
  LocalBundleOptions bundle;
  unsigned seed = 0;  ///< Seeds the two-view RANSACs (OpenCV's PnP RANSAC has a fixed seed).
  [[nodiscard]] std::string Check() const;
};

/// What happened to one keyframe.
struct WalkKeyframeSummary {
  int index = 0;            ///< In the order added.
  int segment = 0;          ///< Its segment when added (0, 1, ...; segments merge later).
  bool registered = false;  ///< Has a pose in its segment (a segment's first keyframe: true).
  /// Why it was not registered to the map (lost, or a new segment after lost ones); empty
  /// when registered, relocalised included.
  std::string failure;
  bool from_prior = false;         ///< Registered with the frame tracker's pose as the prior.
  bool bridged = false;            ///< Registered by the two-view stage against the newest.
  int relocalized_to = -1;         ///< Relocalised against this keyframe (-1: not relocalised).
  int merged_segment = -1;         ///< This keyframe merged that segment into its own (-1: none).
  int loop_to = -1;                ///< Closed a loop with this keyframe (-1: none).
  double loop_correction_m = 0.0;  ///< How far the loop moved this keyframe (map units).
  double loop_s = 0.0;             ///< Of time_s: the loop's pose graph and bundle adjustment.
  /// The background bundle adjustment of the segment was applied at the end of this keyframe
  /// (of time_s: the wait for it, if any, and moving the map).
  bool global_bundle_applied = false;
  double global_bundle_cpu_s = 0.0;  ///< Its own thread's CPU time (not in time_s).
  int prior_matches = 0;             ///< PnP candidates from the search around the prior.
  int matches = 0;                   ///< Descriptor matches to the newest keyframes.
  int matches_3d = 0;                ///< Of them, with a map point (PnP input).
  int projected_matches = 0;         ///< Map points found by projection after the pose.
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
  /// Once `features` is released: the descriptors (8-bit, SIFT's own range) of some keypoints
  /// with a map point (WalkOptions::kept_descriptors), for relocalisation and the search by
  /// projection, sorted by keypoint.
  std::vector<int> kept_keypoints;
  cv::Mat kept_descriptors;  ///< CV_8U, row i of kept_keypoints[i].
  /// 40x30 blurred, zero-mean, unit-norm CV_32F image: place recognition by correlation.
  cv::Mat thumbnail;
  /// Registered to the map it joined: not lost, not a new segment after lost keyframes
  /// (unless that segment was merged into the map later).
  bool joined = false;
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

  /// Adds a keyframe (8-bit gray, undistorted) and registers it. `cam_from_segment_prior`:
  /// its pose in the current segment from the frame tracker, when it has one.
  WalkKeyframeSummary AddKeyframe(const cv::Mat& gray, double timestamp_s,
                                  const Eigen::Isometry3d* cam_from_segment_prior = nullptr);

  [[nodiscard]] const std::vector<WalkKeyframe>& keyframes() const { return keyframes_; }
  [[nodiscard]] const std::vector<WalkPoint>& points() const { return points_; }
  /// Segments with a registered keyframe now (merged ones count once).
  [[nodiscard]] int segments() const;
  /// The segment new keyframes join (-1 before the first).
  [[nodiscard]] int current_segment() const { return segment_; }
  /// The newest keyframe was lost (no pose): the tracker has nothing to track against.
  [[nodiscard]] bool lost() const { return lost_run_ > 0; }
  /// The newest registered keyframe of the current segment (-1: none).
  [[nodiscard]] int newest_keyframe() const;
  [[nodiscard]] int relocalizations() const { return relocalizations_; }
  [[nodiscard]] int merges() const { return merges_; }
  [[nodiscard]] int lost_keyframes() const { return lost_keyframes_; }
  [[nodiscard]] int loop_closures() const { return loop_closures_; }
  /// Background bundle adjustments of a segment applied to the map.
  [[nodiscard]] int global_bundles() const { return global_bundles_; }
  /// CPU time of their threads, in all.
  [[nodiscard]] double global_bundle_cpu_s() const { return global_bundle_cpu_s_; }
  /// Waits for a background bundle adjustment still running and applies it: the map is
  /// final after this (call before reading it for an entry).
  void Finish();
  /// Gives keyframes new poses (index -> cam_from_segment) and points new positions (index ->
  /// position_in_segment), e.g. from a refinement after the walk; every other point whose
  /// first observer moved follows it, X' = T_r'^-1 T_r X.
  void MoveKeyframes(const std::map<int, Eigen::Isometry3d>& cam_from_segment,
                     const std::map<int, Eigen::Vector3d>& position_in_segment = {});
  /// The bundle adjustment of `keyframes` (registered keyframes of `segment`, oldest first;
  /// the first two fixed: gauge and scale): their poses, and each valid point of the segment
  /// that at least `min_observations` of them see, with those observations. `points`
  /// (optional) receives the map index of each of the problem's points.
  [[nodiscard]] LocalBundleProblem BundleProblemOf(const std::vector<int>& keyframes, int segment,
                                                   int min_observations,
                                                   std::vector<int>* points) const;

 private:
  // Indices of the current segment's registered keyframes, oldest first.
  [[nodiscard]] std::vector<int> SegmentKeyframes() const;
  // The newest keyframe of the segment and those sharing the most points with it (up to
  // `count` in all), oldest first.
  [[nodiscard]] std::vector<int> LocalKeyframes(int newest, int count) const;
  void StartSegment(int keyframe);
  // The two-view stage (recon/two_view.h) on the matches of keyframes a and b (seeded by b).
  [[nodiscard]] TwoViewResult TwoView(int a, int b, const std::vector<Match>& matches) const;
  bool Initialize(int keyframe, WalkKeyframeSummary* summary);
  bool Register(int keyframe, const Eigen::Isometry3d* prior, WalkKeyframeSummary* summary);
  enum class Candidates { kAll, kOtherSegments, kLoop };
  // Matches against the earlier keyframes most similar by their thumbnails (`tries` of
  // them, those in `skip` left out); sets the pose (in the candidate's segment) and returns
  // the candidate, or -1.
  int Relocalize(int keyframe, const std::vector<int>& skip, Candidates which, int tries,
                 int min_inliers, Eigen::Isometry3d* cam_from_segment,
                 std::vector<std::pair<int, int>>* inliers, std::vector<Match>* matches);
  // X_other = S X_this fitted to the keyframe's points that are also `inliers`' points
  // (Umeyama 1991, refitted to the pairs within 5 % of their depth); false with fewer than
  // min_merge_points agreeing.
  bool FitSim3(int keyframe, const Eigen::Isometry3d& cam_from_other,
               const std::vector<std::pair<int, int>>& inliers, Eigen::Matrix4d* sim3,
               std::vector<std::pair<int, int>>* agreeing) const;
  // Makes the point pairs (this, other) one point each: the other keeps both tracks.
  void FusePoints(const std::vector<std::pair<int, int>>& pairs);
  // Registers by the two-view stage against the newest keyframe, scaled by the map's points.
  bool Bridge(int keyframe, WalkKeyframeSummary* summary);
  bool TryMerge(int keyframe, WalkKeyframeSummary* summary);
  bool TryCloseLoop(int keyframe, WalkKeyframeSummary* summary);
  // Starts the bundle adjustment of every keyframe of the segment (its two oldest fixed) in
  // the background, after the loop closed by `keyframe`; false (nothing started) when the
  // segment is larger than global_bundle_max_keyframes or _observations.
  bool StartSegmentBundle(int keyframe);
  // Applies the background bundle adjustment (waits for it); `summary` (may be null) is the
  // keyframe's at whose end it happens.
  void ApplySegmentBundle(WalkKeyframeSummary* summary);
  // Sets the keyframe's pose, its observations of the `inliers` (keypoint, point) that
  // reproject, searches the local map by projection and triangulates with `other`.
  void Accept(int keyframe, const Eigen::Isometry3d& cam_from_segment, int segment,
              const std::vector<std::pair<int, int>>& inliers, WalkKeyframeSummary* summary);
  int TriangulateWith(int keyframe, int other, const std::vector<Match>& matches);
  int SearchByProjection(int keyframe, const std::vector<int>& local, double radius_px,
                         const Eigen::Isometry3d& cam_from_segment,
                         std::vector<std::pair<int, int>>* found, bool observe);
  void AdjustWindow(int newest, WalkKeyframeSummary* summary);
  void ReleaseDescriptors(int keyframe);
  // Row `keypoint`'s descriptor as CV_32F (empty when released and not kept).
  [[nodiscard]] cv::Mat Descriptor(int keyframe, int keypoint) const;
  // Descriptors of the keypoints with a valid map point, and those keypoints.
  cv::Mat PointDescriptors(int keyframe, std::vector<int>* keypoints) const;
  [[nodiscard]] Eigen::Vector2d Pixel(int keyframe, int keypoint) const;

  Eigen::Matrix3d K_;
  WalkOptions options_;
  std::vector<WalkKeyframe> keyframes_;
  std::vector<WalkPoint> points_;
  int segment_ = -1;
  int next_segment_ = 0;
  int lost_run_ = 0;
  int relocalizations_ = 0;
  int merges_ = 0;
  int lost_keyframes_ = 0;
  int loop_closures_ = 0;
  int last_loop_keyframe_ = -1;
  int global_bundles_ = 0;
  double global_bundle_cpu_s_ = 0.0;
  // The running background adjustment and what its problem's poses and points are.
  BackgroundBundle segment_bundle_;
  struct SegmentBundleSnapshot {
    int segment = -1;
    int loop_keyframe = -1;
    std::vector<int> keyframes;  // Per pose of the problem, oldest first.
    std::vector<int> points;     // Per point of the problem.
  } segment_bundle_snapshot_;
};

}  // namespace mm
