// Ceres implementation of map/local_bundle.h (the only file of map/ that includes Ceres).

#include <ceres/ceres.h>

#include <cmath>

#include "map/local_bundle.h"
#include "recon/reprojection_residual.h"

namespace mm {

std::string LocalBundleOptions::Check() const {
  if (!(huber_px > 0)) return "huber_px: must be > 0";
  if (max_iterations < 1) return "max_iterations: must be >= 1";
  if (!(function_tolerance > 0)) return "function_tolerance: must be > 0";
  return {};
}

LocalBundleSummary AdjustLocalBundle(const LocalBundleOptions& options,
                                     LocalBundleProblem* problem) {
  LocalBundleSummary summary;
  const size_t num_poses = problem->cam_from_world.size();
  if (problem->pose_fixed.size() != num_poses || problem->observations.empty()) {
    summary.message = "no observations or mismatched pose flags";
    return summary;
  }
  std::vector<Eigen::Quaterniond> rotations(num_poses);
  std::vector<Eigen::Vector3d> translations(num_poses);
  for (size_t i = 0; i < num_poses; ++i) {
    rotations[i] = Eigen::Quaterniond(problem->cam_from_world[i].rotation()).normalized();
    translations[i] = problem->cam_from_world[i].translation();
  }
  ceres::Problem::Options problem_options;
  problem_options.manifold_ownership = ceres::TAKE_OWNERSHIP;
  problem_options.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  ceres::Problem ceres_problem(problem_options);
  ceres::HuberLoss loss(options.huber_px);
  for (size_t i = 0; i < num_poses; ++i) {
    ceres_problem.AddParameterBlock(rotations[i].coeffs().data(), 4,
                                    new ceres::EigenQuaternionManifold());
    ceres_problem.AddParameterBlock(translations[i].data(), 3);
  }
  for (const LocalBundleProblem::Observation& o : problem->observations) {
    ceres_problem.AddResidualBlock(new ceres::AutoDiffCostFunction<PoseReprojection, 2, 4, 3, 3>(
                                       new PoseReprojection(problem->k, o.pixel)),
                                   &loss, rotations[static_cast<size_t>(o.pose)].coeffs().data(),
                                   translations[static_cast<size_t>(o.pose)].data(),
                                   problem->points_in_world[static_cast<size_t>(o.point)].data());
  }
  for (size_t i = 0; i < num_poses; ++i) {
    if (problem->pose_fixed[i]) {
      ceres_problem.SetParameterBlockConstant(rotations[i].coeffs().data());
      ceres_problem.SetParameterBlockConstant(translations[i].data());
    }
  }
  ceres::Solver::Options solver_options;
  solver_options.linear_solver_type = ceres::DENSE_SCHUR;
  solver_options.max_num_iterations = options.max_iterations;
  solver_options.function_tolerance = options.function_tolerance;
  solver_options.num_threads = 1;
  solver_options.logging_type = ceres::SILENT;
  ceres::Solver::Summary ceres_summary;
  ceres::Solve(solver_options, &ceres_problem, &ceres_summary);

  const double residuals = std::max(1.0, static_cast<double>(ceres_summary.num_residuals));
  summary.ran = true;
  summary.iterations = static_cast<int>(ceres_summary.iterations.size());
  summary.initial_rms_px = std::sqrt(2.0 * ceres_summary.initial_cost / residuals);
  summary.final_rms_px = std::sqrt(2.0 * ceres_summary.final_cost / residuals);
  summary.message = ceres_summary.message;
  if (ceres_summary.IsSolutionUsable()) {
    for (size_t i = 0; i < num_poses; ++i) {
      Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
      pose.linear() = rotations[i].normalized().toRotationMatrix();
      pose.translation() = translations[i];
      problem->cam_from_world[i] = pose;
    }
  }
  return summary;
}

}  // namespace mm
