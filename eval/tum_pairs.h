#pragma once
// Evaluation of the two-view reconstruction on a TUM RGB-D style folder (Sturm et al., IROS
// 2012): every pair (i, i + step) of an image list is reconstructed with ReconstructPair and
// compared with the ground-truth trajectory (relative rotation error, translation direction
// error) and, where a depth map of frame i exists, with its depth (value / 5000 m) after one
// median scale factor, and optionally the mesh (eval/mesh_checks.h). Used by `monomesh eval`,
// the accuracy test and bench/.
//
// Thread-safety: EvaluateTumPairs sets OpenCV's thread count (process-wide) when asked to.

#include <filesystem>
#include <string>
#include <vector>

#include "base/stats.h"
#include "calib/camera_model.h"
#include "recon/pipeline.h"
#include "scale/metric_scale.h"
#include "session/recent_frames.h"

namespace mm {

/// Mesh figures of one pair against keyframe A's ground-truth depth (issue 5): coverage of the
/// pixels with ground truth and the relative depth error over them, with the scale taken from
/// the triangulated points.
struct MeshFigures {
  bool valid = false;
  double coverage = 0.0;
  double depth_rel_err_median = 0.0;
  double depth_rel_err_p90 = 0.0;
  double flying = 0.0;  ///< Share of covered pixels off by > 10 %.
  std::string mode;     ///< The mesh the pair got: "dense" or "sparse".
  int vertices = 0;
  int triangles = 0;
  /// Source views the dense sweep used beside B (between A and B, and before A).
  int intermediate_views = 0;
  int views_before_a = 0;                   ///< Of them, before A.
  std::vector<std::string> views_left_out;  ///< Why each other source view was not used.
};

struct EvalOptions {
  std::filesystem::path list;      ///< Image list; empty: <dataset>/rgb.txt. Relative: to dataset.
  int step = 1;                    ///< Pairs (i, i + step).
  int threads = 1;                 ///< cv::setNumThreads for the run (timings are 1 thread).
  double max_depth_dt_s = 0.02;    ///< A depth map belongs to a frame within this time.
  double max_gt_dt_s = 0.1;        ///< Ground-truth extrapolation limit.
  PairOptions pair;                ///< The reconstruction's options.
  /// Pairs more than one frame apart get the middle frame(s) of the list between them as
  /// intermediate views for the dense stage (it takes the one nearest halfway), their
  /// correspondences with A by SIFT matching (in the appliance: the gate's tracks).
  bool intermediate_view = true;
  /// Frames of the list before A, as the daemon keeps them (session/recent_frames.h), as
  /// source views before A (their correspondences with A by SIFT matching; in the appliance:
  /// A's corners tracked back, session/capture_session.h ViewsBeforeA); the reconstruction
  /// poses each and takes the one nearest half of B's distance.
  bool views_before_a = true;
  RecentFramesOptions recent_frames;  ///< Which frames before A (views_before_a).
  bool mesh_figures = false;       ///< Mesh figures where depth is known (EvaluatePairMesh).
  /// Metric scale per pair (scale/metric_scale.h); source none: no scale figures. The
  /// odometry is simulated from the ground truth: each keyframe's camera centre plus
  /// N(0, odom_noise_m) per axis, seeded per pair (odom_seed + index of A).
  ScaleOptions scale;
  double odom_noise_m = 0.0;
  uint32_t odom_seed = 1;
  [[nodiscard]] std::string Check() const;
};

struct PairEval {
  int index_a = 0, index_b = 0;
  double time_a_s = 0, time_b_s = 0;   ///< Dataset timestamps.
  std::string image_a, image_b;
  bool success = false;
  std::string failure_reason;
  std::string classification;
  bool has_gt = false;
  double rot_err_deg = 0, trans_err_deg = 0;   ///< Of the estimate (also when it failed).
  double gt_rotation_deg = 0, gt_baseline_m = 0;
  int features_a = 0, features_b = 0, matches = 0, inliers = 0, points = 0;
  double median_triangulation_angle_deg = 0, reprojection_rms_px = 0;
  StageTimes times;                    ///< features_a_s is keyframe A's own SIFT.
  TwoViewTimes geometry_times;         ///< The geometry stage split up.
  double time_two_images_s = 0;        ///< Whole pair from two images (incl. meshing).
  double time_after_b_s = 0;           ///< Same, minus keyframe A's SIFT.
  double cpu_two_images_s = 0;         ///< Process CPU time of the pair (robust to a busy host).
  double cpu_after_b_s = 0;            ///< Same for the overload with A's features given.
  bool has_depth = false;
  int depth_points = 0;                ///< Points with a valid depth pixel.
  double depth_scale = 0;              ///< Median metres per reconstruction unit.
  double depth_rel_err_median = 0;     ///< Median |s z - d| / d.
  double depth_within_10pct = 0;       ///< Share of points with relative error < 0.1.
  MeshFigures mesh;                    ///< With depth and options.mesh_figures.
  /// With options.scale.source other than none: the estimate, and against the ground truth's
  /// metres per unit (its baseline over the reconstruction's) where both exist.
  bool has_scale = false;
  ScaleEstimate scale;
  double true_metres_per_unit = 0;
  double scale_rel_err = 0;            ///< |estimate / truth - 1| (scaled pairs with GT).
};

struct EvalSummary {
  int pairs = 0, succeeded = 0;
  double rot_err_median_deg = 0, rot_err_p90_deg = 0;     ///< Over succeeded pairs.
  double trans_err_median_deg = 0, trans_err_p90_deg = 0;
  double time_median_s = 0, time_after_b_median_s = 0;
  double cpu_median_s = 0, cpu_after_b_median_s = 0;
  int depth_pairs = 0;
  double depth_rel_err_median = 0;     ///< Median over pairs with depth of their medians.
  double depth_within_10pct = 0;       ///< Mean over those pairs.
  int mesh_pairs = 0;                  ///< Pairs with mesh figures.
  double mesh_coverage = 0;            ///< Median over those pairs.
  double mesh_depth_rel_err_median = 0;  ///< Median over those pairs of their medians.
  double mesh_depth_rel_err_p90 = 0;     ///< Median over those pairs of their p90s.
  double mesh_flying = 0;               ///< Median over those pairs.
  int scale_pairs = 0;                 ///< Succeeded pairs the scale was asked of.
  int scaled_pairs = 0;                ///< Of those, scaled and with ground truth.
  double scale_rel_err_median = 0, scale_rel_err_p90 = 0;  ///< Over the scaled pairs.
};

struct EvalResult {
  bool ok = false;                     ///< False: the dataset could not be read.
  std::string failure_reason;
  std::vector<PairEval> pairs;
  EvalSummary summary;
};

/// Empty when `dataset`/groundtruth.txt is a file, else an error naming it: every evaluation
/// against ground truth (pairs, captures) refuses a folder without one.
[[nodiscard]] std::string MissingGroundTruth(const std::filesystem::path& dataset);

/// Runs the evaluation; dataset errors are reported in the result (ok = false), as is a missing
/// groundtruth.txt or one with no pose near any pair's frames.
EvalResult EvaluateTumPairs(const std::filesystem::path& dataset, const BouguetCamera& camera,
                            const EvalOptions& options);

/// One line per pair (human-readable).
std::string FormatPairLine(const PairEval& p);
/// The summary lines (human-readable).
std::string FormatSummary(const EvalSummary& s);
/// {"summary": {...}, "pairs": [...]}: degrees, seconds, fractions (schema of issue 4).
std::string EvalToJson(const EvalResult& result);

}  // namespace mm
