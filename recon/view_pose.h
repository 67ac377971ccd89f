#pragma once
// The pose of a further view of the pair (a frame between A and B) from the pair's 3-D points:
// its correspondences with A (the keyframe gate's tracks, or feature matches) pick the points
// seen at those pixels of A, and the pose follows by PnP (EPnP in RANSAC, then Levenberg-
// Marquardt on the inliers' reprojection error; Lepetit et al., IJCV 2009), in the pair's
// units. The dense stage sweeps over it as over B (recon/dense.h).
//
// Thread-safety: pure function; reentrant.

#include <Eigen/Core>
#include <span>
#include <string>
#include <vector>

namespace mm {

/// Absolute pose from 3-D points and their pixels: a minimal solver in RANSAC (OpenCV's
/// solvePnPRansac, whose sampler has its own fixed seed: deterministic), then Levenberg-
/// Marquardt on the inliers' reprojection error.
struct PnpRansacOptions {
  double threshold_px = 2.0;  ///< Inlier threshold on the reprojection error.
  int iterations = 200;
  double confidence = 0.999;
  /// The minimal solver: SQPnP (Terzakis & Lourakis, ECCV 2020) instead of EPnP.
  bool sqpnp = false;
};

struct PnpRansacPose {
  bool found = false;  ///< RANSAC found a model (the caller judges the inliers).
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();  ///< x_cam = R X + t.
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();
  std::vector<int> inliers;  ///< Indices into the inputs.
};

/// `points` and `pixels` index-aligned (undistorted pixels seen through K).
PnpRansacPose SolvePnpRansacRefined(std::span<const Eigen::Vector3d> points,
                                    std::span<const Eigen::Vector2d> pixels,
                                    const Eigen::Matrix3d& K, const PnpRansacOptions& options);

struct ViewPoseOptions {
  double threshold_px = 2.0;  ///< RANSAC inlier threshold on the reprojection error.
  int min_inliers = 20;
  double min_inlier_share = 0.5;  ///< Of the correspondences that hit a point.
  /// A correspondence's pixel in A names a point when within this of the point's pixel in A.
  double max_pixel_a_offset_px = 0.01;
  int ransac_iterations = 200;
  [[nodiscard]] std::string Check() const;
};

struct ViewPose {
  bool success = false;
  std::string failure_reason;
  Eigen::Matrix3d rotation_from_a = Eigen::Matrix3d::Identity();  ///< x_view = R x_a + t.
  Eigen::Vector3d translation_from_a = Eigen::Vector3d::Zero();
  int correspondences_on_points = 0;
  int inliers = 0;
  double reprojection_rms_px = 0;  ///< Over the inliers, after the refinement.
};

/// `points_in_a` and `point_pixels_a`: the pair's points and where A observed each;
/// `pixels_a` / `pixels_view`: index-aligned correspondences between A and the view
/// (undistorted pixels); `K`: the intrinsics of both.
ViewPose EstimateViewPose(std::span<const Eigen::Vector3d> points_in_a,
                          std::span<const Eigen::Vector2d> point_pixels_a,
                          std::span<const Eigen::Vector2d> pixels_a,
                          std::span<const Eigen::Vector2d> pixels_view, const Eigen::Matrix3d& K,
                          const ViewPoseOptions& options);

}  // namespace mm
