#pragma once
// Pose-graph optimisation over Sim(3) (Strasdat et al. 2010, "Scale drift-aware large scale
// monocular SLAM"; ORB-SLAM's essential-graph optimisation, Mur-Artal et al. 2015, sec. VII):
// keyframe poses cam_from_world as similarities (x_cam = s R X + t), edges the relative
// similarity measured between two keyframes; the residual of an edge (i -> j, measured M) is
// log(M^-1 * T_j * T_i^-1) approximated by (2 vec(q), t, log s). Fixed poses set the gauge
// (one fixes all seven degrees of freedom). The solver (Ceres) is confined to
// pose_graph_ceres.cc.
//
// Thread-safety: pure function; reentrant.
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <string>
#include <vector>

namespace mm {

/// A similarity x -> scale * rotation * x + translation.
struct Sim3 {
  Eigen::Quaterniond rotation = Eigen::Quaterniond::Identity();
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();
  double scale = 1.0;

  static Sim3 FromIsometry(const Eigen::Isometry3d& t);
  /// From the 4x4 matrix [sR t; 0 1] (e.g. Eigen::umeyama's).
  static Sim3 FromMatrix(const Eigen::Matrix4d& m);
  [[nodiscard]] Sim3 Inverse() const;
  [[nodiscard]] Eigen::Vector3d operator*(const Eigen::Vector3d& x) const;
  [[nodiscard]] Sim3 operator*(const Sim3& other) const;
  /// The camera pose this similarity stands for once the world is rescaled: (R, t / s).
  [[nodiscard]] Eigen::Isometry3d ToIsometry() const;
};

struct PoseGraphOptions {
  int max_iterations = 20;
  double function_tolerance = 1e-8;
  [[nodiscard]] std::string Check() const;
};

struct PoseGraphProblem {
  std::vector<Sim3> cam_from_world;
  std::vector<bool> fixed;  ///< Per pose.
  struct Edge {
    int from = 0;
    int to = 0;
    Sim3 to_from_from;  ///< Measured T_to * T_from^-1.
    double weight = 1.0;
  };
  std::vector<Edge> edges;
};

struct PoseGraphSummary {
  bool ran = false;
  int iterations = 0;
  double initial_cost = 0.0;
  double final_cost = 0.0;
  std::string message;
};

/// Refines the free poses of `problem` in place.
PoseGraphSummary OptimizePoseGraph(const PoseGraphOptions& options, PoseGraphProblem* problem);

}  // namespace mm
