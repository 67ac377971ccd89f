#pragma once
// Relative pose and triangulation from two calibrated, undistorted views.
// Essential matrix by RANSAC (five-point solver of Nister, PAMI 2004, via OpenCV), the
// four-fold (R, t) ambiguity resolved by cheirality over all inliers, then linear (DLT)
// triangulation (Hartley & Zisserman, 2nd ed., sec. 12.2) with reprojection, depth and
// triangulation-angle checks.
//
// Thread-safety: pure functions; reentrant. Same input and seed, same output.

#include <Eigen/Core>
#include <span>
#include <string>
#include <vector>

namespace mm {

struct TwoViewOptions {
  double ransac_threshold_px = 1.0;  ///< Inlier threshold on the epipolar distance.
  double ransac_confidence = 0.999;  ///< Stop when this sure of having an all-inlier sample.
  int max_ransac_iterations = 10000;
  unsigned seed = 0;                 ///< RNG seed: runs are deterministic.
  int min_inliers = 30;              ///< Fewer inliers: the pair fails.
  double max_reprojection_error_px = 4.0;  ///< Drop triangulated points above this.
  double min_triangulation_angle_deg = 0.5;  ///< Drop points seen under a smaller angle.
  double min_median_triangulation_angle_deg = 1.0;  ///< Below: "too little parallax".
  [[nodiscard]] std::string Check() const;
};

struct TwoViewResult {
  bool success = false;
  std::string failure_reason;  ///< Why it failed, for reports; empty on success.

  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();  ///< cam_b_from_cam_a rotation.
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();   ///< cam_b_from_cam_a, unit norm.

  std::vector<Eigen::Vector3d> points_in_cam_a;  ///< Triangulated points (baseline = 1).
  std::vector<int> point_correspondence;         ///< Index into the input pairs, per point.

  int num_correspondences = 0;
  int num_inliers = 0;
  double median_triangulation_angle_deg = 0.0;
  double reprojection_rms_px = 0.0;
};

/// Estimates cam_b_from_cam_a and triangulates the inliers. `pixels_a[i]` and `pixels_b[i]`
/// are one correspondence in undistorted pixels of a camera with intrinsics `K`.
TwoViewResult EstimateTwoView(std::span<const Eigen::Vector2d> pixels_a,
                              std::span<const Eigen::Vector2d> pixels_b, const Eigen::Matrix3d& K,
                              const TwoViewOptions& options);

/// Linear triangulation (DLT) of one correspondence in normalized coordinates, with camera A
/// at the origin and B = [R | t]. Returns the point in camera A.
Eigen::Vector3d TriangulateDlt(const Eigen::Vector2d& x_a, const Eigen::Vector2d& x_b,
                               const Eigen::Matrix3d& rotation, const Eigen::Vector3d& translation);

}  // namespace mm
