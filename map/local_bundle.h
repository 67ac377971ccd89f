#pragma once
// Bundle adjustment over many keyframes behind a solver-neutral interface (Triggs et al. 1999):
// poses cam_from_world (angle-axis + translation), points in world, fixed intrinsics, a Huber
// loss on the pixel residuals. Poses marked fixed are constants (the gauge and, with two of
// them, the scale). The solver (Ceres) is confined to local_bundle_ceres.cc.
//
// Thread-safety: pure function; reentrant.
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <string>
#include <vector>

namespace mm {

struct LocalBundleOptions {
  double huber_px = 1.0;
  int max_iterations = 10;  ///< The window moves little per keyframe (measured: 10 as good as 20).
  double function_tolerance = 1e-6;
  [[nodiscard]] std::string Check() const;
};

struct LocalBundleProblem {
  Eigen::Matrix3d k = Eigen::Matrix3d::Identity();
  std::vector<Eigen::Isometry3d> cam_from_world;
  std::vector<bool> pose_fixed;  ///< Per pose.
  std::vector<Eigen::Vector3d> points_in_world;
  struct Observation {
    int pose = 0;
    int point = 0;
    Eigen::Vector2d pixel = Eigen::Vector2d::Zero();
  };
  std::vector<Observation> observations;
};

struct LocalBundleSummary {
  bool ran = false;
  int iterations = 0;
  double initial_rms_px = 0.0;
  double final_rms_px = 0.0;
  std::string message;
};

/// Refines the free poses and every point of `problem` in place.
LocalBundleSummary AdjustLocalBundle(const LocalBundleOptions& options,
                                     LocalBundleProblem* problem);

}  // namespace mm
