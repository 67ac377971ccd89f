#pragma once
// Two-view bundle adjustment behind a solver-neutral interface (Triggs et al., "Bundle
// Adjustment - A Modern Synthesis", 1999). Camera A is fixed at the origin (gauge), camera B's
// translation stays on the unit sphere (scale gauge), intrinsics are fixed, and a Huber loss
// bounds the influence of residual outliers. The solver (Ceres) is confined to
// bundle_adjustment_ceres.cc.
//
// Thread-safety: pure function; reentrant.

#include <Eigen/Core>
#include <string>
#include <vector>

namespace mm {

struct BundleOptions {
  double huber_px = 1.0;      ///< Huber loss scale on the pixel residuals.
  int max_iterations = 50;    ///< Solver iterations (Levenberg-Marquardt).
  double function_tolerance = 1e-8;
  [[nodiscard]] std::string Check() const;
};

struct BundleSummary {
  bool ran = false;
  bool converged = false;
  int iterations = 0;
  int num_points = 0;
  double initial_rms_px = 0.0;  ///< sqrt(2 * cost / residuals) before; robustified cost.
  double final_rms_px = 0.0;
  double time_s = 0.0;
  std::string message;          ///< The solver's termination message.
};

/// In/out: cam_b_from_cam_a (|t| = 1) and the points in camera A; observations in pixels.
struct TwoViewBundleProblem {
  Eigen::Matrix3d k = Eigen::Matrix3d::Identity();
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();
  Eigen::Vector3d translation = Eigen::Vector3d::UnitX();
  std::vector<Eigen::Vector3d> points;
  std::vector<Eigen::Vector2d> observations_a;
  std::vector<Eigen::Vector2d> observations_b;
};

/// Refines `problem` in place and summarizes the solve.
BundleSummary AdjustTwoViewBundle(const BundleOptions& options, TwoViewBundleProblem* problem);

}  // namespace mm
