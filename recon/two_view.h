#pragma once
// Relative pose and triangulation from two calibrated, undistorted views:
//   F by RANSAC (H&Z alg. 11.4, recon/epipolar.h) and H by RANSAC -> pair classification
//   (general / planar / pure rotation / too little parallax) -> E = K^T F K on the essential
//   manifold -> the four (R, t) with cheirality over all inliers (clear-winner rule; a planar
//   pair takes its pose from H's decomposition instead) ->
//   LM on the Sampson error over (R, t) -> linear + refined triangulation -> parallax gate ->
//   two-view bundle adjustment (recon/bundle_adjustment.h) -> point rejection by reprojection
//   error and triangulation angle.
//
// Thread-safety: pure functions; reentrant. Same input and seed, same output.

#include <Eigen/Core>
#include <span>
#include <string>
#include <vector>

#include "recon/bundle_adjustment.h"
#include "recon/epipolar.h"

namespace mm {

struct TwoViewOptions {
  double ransac_threshold_px = 1.0;  ///< Inlier threshold on the Sampson distance (pixels).
  double ransac_confidence = 0.9999; ///< Adaptive stop (H&Z alg. 4.5).
  int max_ransac_iterations = 10000;
  int f_refine_iterations = 20;      ///< LM iterations of F on its RANSAC inliers (0: none).
  unsigned seed = 0;                 ///< RNG seed: runs are deterministic.
  /// LO-RANSAC for F (RansacOptions::local_optimization): a new best sample's model is
  /// refitted on its inliers before it is scored.
  bool lo_ransac = false;
  int min_inliers = 30;              ///< Fewer inliers / points: the pair fails.
  double max_reprojection_error_px = 4.0;  ///< Drop triangulated points above (before BA).
  double max_reprojection_error_after_ba_px = 2.0;  ///< Drop points above this after BA.
  double min_triangulation_angle_deg = 0.5;  ///< Drop points seen under a smaller angle.
  double min_median_triangulation_angle_deg = 1.0;  ///< Below: "too little parallax".
  bool bundle_adjustment = true;     ///< Run the two-view BA.
  /// A pair a homography explains that is not a rotation (a wall, a floor) takes its pose from
  /// the homography's decomposition instead of failing as planar; the rest (LM on the
  /// Sampson error, triangulation, the parallax test, BA) is as for a general pair.
  bool planar_from_h = true;
  BundleOptions bundle;
  CheiralityOptions cheirality;
  ClassifyOptions classify;
  [[nodiscard]] std::string Check() const;
};

/// Why a pair failed, for callers that act on it (the capture tries a later keyframe B when
/// more motion can cure the failure: MoreMotionMayCure).
enum class TwoViewFailure {
  kNone,
  kInput,          ///< Correspondence counts differ.
  kTooFewMatches,  ///< Fewer correspondences than min_inliers.
  kNoModel,        ///< RANSAC found no F.
  kNoParallax,     ///< The image barely moved, or the median triangulation angle is too small.
  kRotation,       ///< A homography explains the pair and it is a rotation.
  kPlanar,         ///< A homography explains the pair (a plane, or too little depth range).
  kTooFewInliers,  ///< Fewer F inliers than min_inliers, before or after the refinement.
  kCheirality,     ///< No pose puts the points in front of both cameras, or no clear winner.
  kTooFewPoints,   ///< Too few points survive triangulation or the bundle adjustment.
};
const char* TwoViewFailureName(TwoViewFailure failure);

/// True for the failures a larger baseline from the same keyframe A can cure: too little
/// parallax, pure rotation, a homography that explains the pair, no clear cheirality winner.
bool MoreMotionMayCure(TwoViewFailure failure);

struct TwoViewTimes {
  double ransac_f_s = 0, ransac_h_s = 0, pose_s = 0, triangulation_s = 0, bundle_s = 0;
  [[nodiscard]] double total_s() const {
    return ransac_f_s + ransac_h_s + pose_s + triangulation_s + bundle_s;
  }
};

struct TwoViewResult {
  bool success = false;
  std::string failure_reason;  ///< Why it failed, for reports; empty on success.
  TwoViewFailure failure = TwoViewFailure::kNone;
  PairClassification classification;

  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();  ///< cam_b_from_cam_a rotation.
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();   ///< cam_b_from_cam_a, unit norm.

  std::vector<Eigen::Vector3d> points_in_cam_a;  ///< Triangulated points (baseline = 1).
  std::vector<int> point_correspondence;         ///< Index into the input pairs, per point.
  std::vector<int> inliers;                      ///< Epipolar inliers under the refined pose.

  int num_correspondences = 0;
  int num_inliers = 0;                 ///< = inliers.size().
  RansacResult ransac_f;               ///< Stats of the F RANSAC (model, iterations, inliers).
  RansacResult ransac_h;
  CheiralityResult cheirality;
  BundleSummary bundle;
  double median_triangulation_angle_deg = 0.0;
  double reprojection_rms_px = 0.0;    ///< Of the kept points, both views.
  TwoViewTimes times;
};

/// The two-view stage's acceptance test before any refinement, shared with the keyframe gate
/// so that both agree on "enough parallax": F and H by RANSAC (max_ransac_iterations caps both),
/// ClassifyPair, the F inlier count, E = K^T F K, the pose by cheirality, then the linear
/// triangulation of the F inliers and their median triangulation angle against
/// min_median_triangulation_angle_deg. EstimateTwoView runs steps 1-2 through this.
struct TwoViewProbe {
  bool accepted = false;  ///< Passed every test (the pair is worth a reconstruction).
  std::string failure_reason;
  TwoViewFailure failure = TwoViewFailure::kNone;
  RansacResult ransac_f;
  RansacResult ransac_h;
  PairClassification classification;
  CheiralityResult cheirality;
  double median_triangulation_angle_deg = 0.0;  ///< Of the F inliers in front (linear).
  /// The correspondences in normalized coordinates (K^-1 x), filled once the pose is sought.
  std::vector<Eigen::Vector2d> norm_a, norm_b;
  double ransac_f_s = 0.0, ransac_h_s = 0.0, pose_s = 0.0;
};
TwoViewProbe ProbeTwoView(std::span<const Eigen::Vector2d> pixels_a,
                          std::span<const Eigen::Vector2d> pixels_b, const Eigen::Matrix3d& K,
                          const TwoViewOptions& options);

/// Estimates cam_b_from_cam_a and triangulates the inliers. `pixels_a[i]` and `pixels_b[i]`
/// are one correspondence in undistorted pixels of a camera with intrinsics `K`.
TwoViewResult EstimateTwoView(std::span<const Eigen::Vector2d> pixels_a,
                              std::span<const Eigen::Vector2d> pixels_b, const Eigen::Matrix3d& K,
                              const TwoViewOptions& options);

}  // namespace mm
