#pragma once
// Relative pose and triangulation from two calibrated, undistorted views:
//   F by RANSAC (H&Z alg. 11.4, recon/epipolar.h) and H by RANSAC -> pair classification
//   (general / planar / pure rotation / too little parallax) -> E = K^T F K on the essential
//   manifold -> the four (R, t) with cheirality over all inliers (clear-winner rule) ->
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
  BundleOptions bundle;
  CheiralityOptions cheirality;
  ClassifyOptions classify;
  [[nodiscard]] std::string Check() const;
};

struct TwoViewTimes {
  double ransac_f_s = 0, ransac_h_s = 0, pose_s = 0, triangulation_s = 0, bundle_s = 0;
  [[nodiscard]] double total_s() const {
    return ransac_f_s + ransac_h_s + pose_s + triangulation_s + bundle_s;
  }
};

struct TwoViewResult {
  bool success = false;
  std::string failure_reason;  ///< Why it failed, for reports; empty on success.
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

/// Estimates cam_b_from_cam_a and triangulates the inliers. `pixels_a[i]` and `pixels_b[i]`
/// are one correspondence in undistorted pixels of a camera with intrinsics `K`.
TwoViewResult EstimateTwoView(std::span<const Eigen::Vector2d> pixels_a,
                              std::span<const Eigen::Vector2d> pixels_b, const Eigen::Matrix3d& K,
                              const TwoViewOptions& options);

}  // namespace mm
