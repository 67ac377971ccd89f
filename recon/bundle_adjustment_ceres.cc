// Ceres implementation of recon/bundle_adjustment.h (the only file that includes Ceres).

#include <ceres/ceres.h>
#include <ceres/rotation.h>

#include <Eigen/Geometry>
#include <chrono>
#include <cmath>

#include "recon/bundle_adjustment.h"
#include "recon/reprojection_residual.h"

namespace mm {

std::string BundleOptions::Check() const {
  if (!(huber_px > 0)) return "huber_px: must be > 0";
  if (max_iterations < 1) return "max_iterations: must be >= 1";
  if (!(function_tolerance > 0)) return "function_tolerance: must be > 0";
  return {};
}

BundleSummary AdjustTwoViewBundle(const BundleOptions& options, TwoViewBundleProblem* problem) {
  const auto start = std::chrono::steady_clock::now();
  BundleSummary summary;
  const size_t n = problem->points.size();
  summary.num_points = static_cast<int>(n);
  if (n < 5 || problem->observations_a.size() != n || problem->observations_b.size() != n) {
    summary.message = "too few points or mismatched observations";
    return summary;
  }
  Eigen::Quaterniond q(problem->rotation);
  q.normalize();
  Eigen::Vector3d t = problem->translation.normalized();

  ceres::Problem::Options problem_options;
  problem_options.manifold_ownership = ceres::TAKE_OWNERSHIP;
  // One loss object shared by every residual, owned here.
  problem_options.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  ceres::Problem ceres_problem(problem_options);
  ceres::HuberLoss loss(options.huber_px);
  ceres_problem.AddParameterBlock(q.coeffs().data(), 4, new ceres::EigenQuaternionManifold());
  ceres_problem.AddParameterBlock(t.data(), 3, new ceres::SphereManifold<3>());
  for (size_t i = 0; i < n; ++i) {
    double* p = problem->points[i].data();
    ceres_problem.AddResidualBlock(
        new ceres::AutoDiffCostFunction<PointReprojection, 2, 3>(
            new PointReprojection(problem->k, problem->observations_a[i])),
        &loss, p);
    ceres_problem.AddResidualBlock(
        new ceres::AutoDiffCostFunction<PoseReprojection, 2, 4, 3, 3>(
            new PoseReprojection(problem->k, problem->observations_b[i])),
        &loss, q.coeffs().data(), t.data(), p);
  }
  ceres::Solver::Options solver_options;
  solver_options.linear_solver_type = ceres::DENSE_SCHUR;
  solver_options.max_num_iterations = options.max_iterations;
  solver_options.function_tolerance = options.function_tolerance;
  solver_options.num_threads = 1;
  solver_options.logging_type = ceres::SILENT;
  ceres::Solver::Summary ceres_summary;
  ceres::Solve(solver_options, &ceres_problem, &ceres_summary);

  const double residuals = static_cast<double>(ceres_summary.num_residuals);
  summary.ran = true;
  summary.converged = ceres_summary.termination_type == ceres::CONVERGENCE;
  summary.iterations = static_cast<int>(ceres_summary.iterations.size());
  summary.initial_rms_px = std::sqrt(2.0 * ceres_summary.initial_cost / std::max(residuals, 1.0));
  summary.final_rms_px = std::sqrt(2.0 * ceres_summary.final_cost / std::max(residuals, 1.0));
  summary.message = ceres_summary.message;
  if (ceres_summary.IsSolutionUsable()) {
    problem->rotation = q.normalized().toRotationMatrix();
    problem->translation = t.normalized();
  }
  summary.time_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return summary;
}

}  // namespace mm
