#pragma once
// Evaluation of a walk (map/walk_map.h) on a TUM RGB-D style folder: the frames of a list go
// through the walk, every frame a keyframe (`every_frame`) or the keyframes chosen by the
// gate (recon/keyframe_gate.h: a new keyframe when the rotation-compensated parallax against
// the last one passes the threshold, as in the daemon's walk). The keyframe poses are compared
// with the ground truth:
//   ATE: RMSE of the camera centres after a Sim(3) alignment (Umeyama 1991), over the
//        registered keyframes of the largest segment (Sturm et al. 2012, sec. VI-B);
//   RPE: per consecutive keyframe pair, the rotation error of the relative pose;
//   scale drift: the Sim(3) scales fitted to the first and to the last third of the
//        keyframes, |s_last / s_first - 1|.
// Used by `monomesh eval --walk`, the walk accuracy test and bench/.
//
// Thread-safety: EvaluateWalk sets OpenCV's thread count (process-wide) when asked to.

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <filesystem>
#include <string>
#include <vector>

#include "calib/camera_model.h"
#include "map/walk_map.h"
#include "map/walk_mesh.h"
#include "map/walk_refine.h"
#include "recon/keyframe_gate.h"

namespace mm {

struct WalkEvalOptions {
  std::filesystem::path list;    ///< Image list; empty: <dataset>/rgb.txt. Relative: to dataset.
  bool every_frame = false;      ///< Every listed frame a keyframe; else the gate chooses.
  int threads = 1;               ///< cv::setNumThreads for the run (timings are 1 thread).
  double max_gt_dt_s = 0.1;      ///< Ground-truth extrapolation limit.
  double max_depth_dt_s = 0.02;  ///< A depth map belongs to a keyframe within this time.
  /// The daemon's, but a loop's background bundle adjustment is applied two keyframes after
  /// the loop (waited for), so that the figures are the same on every run.
  WalkOptions walk = [] {
    WalkOptions w;
    w.global_bundle_apply_after = 2;
    return w;
  }();
  KeyframeGateOptions gate;  ///< Without every_frame.
  /// The map mesh (map/walk_mesh.h) of the evaluated segment, aligned by the Sim(3) and
  /// rendered from the ground-truth poses of this many keyframes evenly along the path,
  /// against their depth maps; 0: no mesh.
  int map_depth_views = 5;
  WalkMeshOptions mesh;
  /// After the walk, as the daemon does: the evaluated segment refined from tracks built
  /// across its keyframes (map/walk_refine.h), before the figures and the mesh.
  bool refine = true;
  TrackRefineOptions refinement;
  [[nodiscard]] std::string Check() const;
};

struct WalkKeyframeEval {
  WalkKeyframeSummary walk;  ///< What the walk did with it.
  int segment = 0;           ///< Its segment in the final map (after merges).
  std::string reason;        ///< Why the tracker made it a keyframe (WalkFrameStep).
  int frame = 0;             ///< Index in the list.
  double timestamp_s = 0.0;
  std::string image;
  double cpu_s = 0.0;  ///< Thread CPU time of AddKeyframe.
  bool has_gt = false;
  bool in_evaluated_segment = false;
  double position_err_m = 0.0;  ///< After the alignment (evaluated segment only).
  Eigen::Vector3d centre_in_segment = Eigen::Vector3d::Zero();  ///< Estimated (final map).
  Eigen::Vector3d centre_gt = Eigen::Vector3d::Zero();          ///< Ground truth (has_gt).
  double rpe_rot_deg = -1.0;                 ///< To the previous keyframe of its segment; -1: none.
  int depth_points = 0;                      ///< Its map points compared with its depth map.
  double point_depth_rel_err_median = -1.0;  ///< -1: no depth map.
  /// Median of depth-map depth / map depth over its points: the map's local scale (metres
  /// per map unit) at the keyframe, whose change along the walk is its scale drift.
  double depth_scale = 0.0;
};

struct WalkEvalSummary {
  int frames = 0;  ///< Frames read.
  int keyframes = 0;
  /// Keyframes registered to the map they were added to: all but those that started a new
  /// segment after a failed registration (the walk's first keyframe counts).
  int registered = 0;
  int segments = 0;
  int evaluated_segment = 0;  ///< The largest segment, which the figures below are of.
  int evaluated_keyframes = 0;
  double ate_rmse_m = 0.0;
  double ate_max_m = 0.0;
  double path_length_m = 0.0;  ///< Ground-truth path through the evaluated keyframes.
  double sim3_scale = 0.0;     ///< Metres per map unit of the alignment.
  double rpe_rot_deg_median = 0.0;
  double scale_drift = 0.0;  ///< 0 when a third has fewer than 3 keyframes.
  /// The same from the depth maps: |m_last / m_first - 1| of the median local scale
  /// (WalkKeyframeEval::depth_scale) of the first and of the last third's keyframes; 0
  /// without depth maps (fewer than 3 in a third). The trajectory's figure also holds the
  /// ground truth's pose errors over a third's path; this one only the map's depths.
  double depth_scale_drift = 0.0;
  double cpu_per_keyframe_s_median = 0.0;
  /// Thread CPU time of the frames that did not become keyframes (tracking and the gate).
  double cpu_per_frame_s_median = 0.0;
  int tracked_frames = 0;  ///< Of those, with a pose from the tracked map points.
  int relocalizations = 0;
  int merges = 0;         ///< Segments merged into another.
  int loop_closures = 0;  ///< Loops closed (a keyframe recognised in its own segment).
  /// Background bundle adjustments of a segment after a loop, applied; their threads' CPU
  /// (not in cpu_total_s).
  int global_bundles = 0;
  double global_bundle_cpu_s = 0.0;
  int lost_keyframes = 0;    ///< Keyframes neither registered nor relocalised.
  double cpu_total_s = 0.0;  ///< All frames, gate included.
  int points = 0;            ///< Valid map points.
  /// The map points' depth in each evaluated keyframe that has a depth map (depth.txt,
  /// value / 5000 m), times the alignment's scale, against that depth: the median over all
  /// observations of |s z - d| / d (0 points: no depth maps).
  int depth_points = 0;
  int depth_keyframes = 0;
  double point_depth_rel_err_median = 0.0;
  double point_depth_rel_err_p90 = 0.0;
  /// The map mesh from `map_depth_views` ground-truth poses: per view the median of
  /// |d_mesh - d_gt| / d_gt over the pixels both cover; the median and the largest of those
  /// medians, the largest p90, and the mean share of ground-truth pixels the mesh covers.
  int map_depth_views = 0;
  double map_depth_rel_err_median = 0.0;
  double map_depth_rel_err_max_median = 0.0;
  double map_depth_rel_err_p90_max = 0.0;
  double map_coverage_mean = 0.0;
  std::vector<double> map_depth_rel_err_per_view;  ///< Each view's median, along the path.
  /// Each view's median of d_mesh / d_gt (1: no bias; MeshDepthEval::median_ratio).
  std::vector<double> map_depth_ratio_per_view;
  std::vector<double> map_coverage_per_view;
  int map_mesh_parts = 0;
  int map_mesh_triangles = 0;
  int map_mesh_dropped_overlap = 0;     ///< WalkMeshSummary::dropped_overlap.
  int map_mesh_dropped_free_space = 0;  ///< WalkMeshSummary::dropped_free_space.
  double map_mesh_cpu_s = 0.0;          ///< Thread CPU time of BuildWalkMesh.
  TrackRefineSummary refinement;        ///< Its CPU is not in cpu_total_s.
};

struct WalkEvalResult {
  bool ok = false;
  std::string failure_reason;
  std::vector<WalkKeyframeEval> keyframes;
  WalkEvalSummary summary;
};

/// Sim(3) that maps `source` onto `target` (columns are points) in the least-squares sense
/// (Umeyama 1991); needs >= 3 points not all on a line.
Eigen::Matrix4d AlignSim3(const Eigen::Matrix3Xd& source, const Eigen::Matrix3Xd& target);

/// Runs the walk on the dataset; dataset errors are reported in the result (ok = false).
WalkEvalResult EvaluateWalk(const std::filesystem::path& dataset, const BouguetCamera& camera,
                            const WalkEvalOptions& options);

std::string FormatWalkKeyframeLine(const WalkKeyframeEval& k);
std::string FormatWalkSummary(const WalkEvalSummary& s);
/// {"summary": {"walk": {...}}, "keyframes": [...]}: metres, degrees, seconds.
std::string WalkEvalToJson(const WalkEvalResult& result);

}  // namespace mm
