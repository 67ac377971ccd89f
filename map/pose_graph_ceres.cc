// Ceres implementation of map/pose_graph.h (Sim(3) pose graph).

#include <ceres/ceres.h>
#include <ceres/rotation.h>

#include <cmath>

#include "map/pose_graph.h"

namespace mm {
namespace {

// Residual of one edge: E = M^-1 * T_j * T_i^-1 as (2 vec(q_E), t_E, log s_E), weighted.
// Parameters per pose: quaternion (Eigen order x y z w), translation, log scale.
struct Sim3EdgeResidual {
  Sim3EdgeResidual(const Sim3& measured, double edge_weight)
      : inverse_measured(measured.Inverse()), weight(edge_weight) {}

  template <typename T>
  bool operator()(const T* q_i, const T* t_i, const T* log_s_i, const T* q_j, const T* t_j,
                  const T* log_s_j, T* residual) const {
    using Quaternion = Eigen::Quaternion<T>;
    using Vector3 = Eigen::Matrix<T, 3, 1>;
    const Eigen::Map<const Quaternion> rot_i(q_i), rot_j(q_j);
    const Eigen::Map<const Vector3> tr_i(t_i), tr_j(t_j);
    const T s_i = exp(log_s_i[0]);
    const T s_j = exp(log_s_j[0]);
    // T_i^-1: (1/s_i, R_i^T, -(1/s_i) R_i^T t_i).
    const Quaternion rot_i_inv = rot_i.conjugate();
    const T s_i_inv = T(1) / s_i;
    const Vector3 tr_i_inv = -(s_i_inv * (rot_i_inv * tr_i));
    // A = T_j * T_i^-1.
    const Quaternion rot_a = rot_j * rot_i_inv;
    const T s_a = s_j * s_i_inv;
    const Vector3 tr_a = s_j * (rot_j * tr_i_inv) + tr_j;
    // E = M^-1 * A.
    const Quaternion rot_m = inverse_measured.rotation.cast<T>();
    const Vector3 tr_m = inverse_measured.translation.cast<T>();
    const T s_m = T(inverse_measured.scale);
    Quaternion rot_e = rot_m * rot_a;
    if (rot_e.w() < T(0)) rot_e.coeffs() = -rot_e.coeffs();
    const Vector3 tr_e = s_m * (rot_m * tr_a) + tr_m;
    const T s_e = s_m * s_a;
    const T w(weight);
    residual[0] = w * T(2) * rot_e.x();
    residual[1] = w * T(2) * rot_e.y();
    residual[2] = w * T(2) * rot_e.z();
    residual[3] = w * tr_e.x();
    residual[4] = w * tr_e.y();
    residual[5] = w * tr_e.z();
    residual[6] = w * log(s_e);
    return true;
  }

  Sim3 inverse_measured;
  double weight;
};

}  // namespace

Sim3 Sim3::FromIsometry(const Eigen::Isometry3d& t) {
  Sim3 out;
  out.rotation = Eigen::Quaterniond(t.rotation()).normalized();
  out.translation = t.translation();
  return out;
}

Sim3 Sim3::FromMatrix(const Eigen::Matrix4d& m) {
  Sim3 out;
  out.scale = m.topLeftCorner<3, 3>().col(0).norm();
  out.rotation = Eigen::Quaterniond(Eigen::Matrix3d(m.topLeftCorner<3, 3>() / out.scale));
  out.rotation.normalize();
  out.translation = m.topRightCorner<3, 1>();
  return out;
}

Sim3 Sim3::Inverse() const {
  Sim3 out;
  out.rotation = rotation.conjugate();
  out.scale = 1.0 / scale;
  out.translation = -(out.scale * (out.rotation * translation));
  return out;
}

Eigen::Vector3d Sim3::operator*(const Eigen::Vector3d& x) const {
  return scale * (rotation * x) + translation;
}

Sim3 Sim3::operator*(const Sim3& other) const {
  Sim3 out;
  out.rotation = (rotation * other.rotation).normalized();
  out.scale = scale * other.scale;
  out.translation = scale * (rotation * other.translation) + translation;
  return out;
}

Eigen::Isometry3d Sim3::ToIsometry() const {
  Eigen::Isometry3d out = Eigen::Isometry3d::Identity();
  out.linear() = rotation.toRotationMatrix();
  out.translation() = translation / scale;
  return out;
}

std::string PoseGraphOptions::Check() const {
  if (max_iterations < 1) return "max_iterations: must be >= 1";
  if (!(function_tolerance > 0)) return "function_tolerance: must be > 0";
  return {};
}

PoseGraphSummary OptimizePoseGraph(const PoseGraphOptions& options, PoseGraphProblem* problem) {
  PoseGraphSummary summary;
  const size_t n = problem->cam_from_world.size();
  if (problem->fixed.size() != n || problem->edges.empty()) {
    summary.message = "no edges or mismatched pose flags";
    return summary;
  }
  std::vector<Eigen::Quaterniond> rotations(n);
  std::vector<Eigen::Vector3d> translations(n);
  std::vector<double> log_scales(n);
  for (size_t i = 0; i < n; ++i) {
    rotations[i] = problem->cam_from_world[i].rotation.normalized();
    translations[i] = problem->cam_from_world[i].translation;
    log_scales[i] = std::log(problem->cam_from_world[i].scale);
  }
  ceres::Problem::Options problem_options;
  problem_options.manifold_ownership = ceres::TAKE_OWNERSHIP;
  ceres::Problem ceres_problem(problem_options);
  for (size_t i = 0; i < n; ++i) {
    ceres_problem.AddParameterBlock(rotations[i].coeffs().data(), 4,
                                    new ceres::EigenQuaternionManifold());
    ceres_problem.AddParameterBlock(translations[i].data(), 3);
    ceres_problem.AddParameterBlock(&log_scales[i], 1);
  }
  for (const PoseGraphProblem::Edge& e : problem->edges) {
    const auto i = static_cast<size_t>(e.from);
    const auto j = static_cast<size_t>(e.to);
    ceres_problem.AddResidualBlock(
        new ceres::AutoDiffCostFunction<Sim3EdgeResidual, 7, 4, 3, 1, 4, 3, 1>(
            new Sim3EdgeResidual(e.to_from_from, e.weight)),
        nullptr, rotations[i].coeffs().data(), translations[i].data(), &log_scales[i],
        rotations[j].coeffs().data(), translations[j].data(), &log_scales[j]);
  }
  for (size_t i = 0; i < n; ++i) {
    if (!problem->fixed[i]) continue;
    ceres_problem.SetParameterBlockConstant(rotations[i].coeffs().data());
    ceres_problem.SetParameterBlockConstant(translations[i].data());
    ceres_problem.SetParameterBlockConstant(&log_scales[i]);
  }
  ceres::Solver::Options solver_options;
  solver_options.linear_solver_type = ceres::SPARSE_NORMAL_CHOLESKY;
  solver_options.max_num_iterations = options.max_iterations;
  solver_options.function_tolerance = options.function_tolerance;
  solver_options.num_threads = 1;
  solver_options.logging_type = ceres::SILENT;
  ceres::Solver::Summary ceres_summary;
  ceres::Solve(solver_options, &ceres_problem, &ceres_summary);
  summary.ran = true;
  summary.iterations = static_cast<int>(ceres_summary.iterations.size());
  summary.initial_cost = ceres_summary.initial_cost;
  summary.final_cost = ceres_summary.final_cost;
  summary.message = ceres_summary.message;
  if (ceres_summary.IsSolutionUsable()) {
    for (size_t i = 0; i < n; ++i) {
      problem->cam_from_world[i].rotation = rotations[i].normalized();
      problem->cam_from_world[i].translation = translations[i];
      problem->cam_from_world[i].scale = std::exp(log_scales[i]);
    }
  }
  return summary;
}

}  // namespace mm
