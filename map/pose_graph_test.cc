#include "map/pose_graph.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace mm {
namespace {

Sim3 RandomSim3(std::mt19937* rng) {
  std::normal_distribution<double> n(0.0, 1.0);
  Sim3 s;
  s.rotation = Eigen::Quaterniond(
      Eigen::AngleAxisd(0.5 * n(*rng), Eigen::Vector3d(n(*rng), n(*rng), n(*rng)).normalized()));
  s.translation = Eigen::Vector3d(n(*rng), n(*rng), n(*rng));
  s.scale = std::exp(0.2 * n(*rng));
  return s;
}

TEST(Sim3, ComposesAndInvertsAsMaps) {
  std::mt19937 rng(3);
  const Sim3 a = RandomSim3(&rng), b = RandomSim3(&rng);
  const Eigen::Vector3d x(0.3, -1.2, 2.5);
  EXPECT_LT(((a * b) * x - a * (b * x)).norm(), 1e-12);
  EXPECT_LT((a.Inverse() * (a * x) - x).norm(), 1e-12);
  Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
  m.topLeftCorner<3, 3>() = a.scale * a.rotation.toRotationMatrix();
  m.topRightCorner<3, 1>() = a.translation;
  EXPECT_LT((Sim3::FromMatrix(m) * x - a * x).norm(), 1e-12);
}

// A ring of 12 cameras (cam_from_world) whose odometry edges drift in scale (2 % a step)
// and heading; the loop edge from the last back to the first holds the truth. The graph
// spreads the drift: every camera centre ends nearer the truth than before.
TEST(PoseGraph, LoopEdgeRemovesAccumulatedScaleDrift) {
  const int n = 12;
  std::vector<Sim3> truth;
  for (int i = 0; i < n; ++i) {
    const double a = 2.0 * M_PI * i / n;
    Eigen::Isometry3d world_from_cam = Eigen::Isometry3d::Identity();
    world_from_cam.linear() = Eigen::AngleAxisd(a, Eigen::Vector3d::UnitY()).toRotationMatrix();
    world_from_cam.translation() = Eigen::Vector3d(2.0 * std::cos(a), 0.0, 2.0 * std::sin(a));
    truth.push_back(Sim3::FromIsometry(world_from_cam.inverse()));
  }
  PoseGraphProblem graph;
  // Dead reckoning with drifting odometry: each step 2 % longer and 0.5 deg off.
  graph.cam_from_world.push_back(truth[0]);
  graph.fixed.push_back(true);
  Sim3 drift;
  drift.scale = 1.0 / 1.02;
  drift.rotation =
      Eigen::Quaterniond(Eigen::AngleAxisd(0.5 * M_PI / 180, Eigen::Vector3d::UnitX()));
  for (int i = 1; i < n; ++i) {
    const Sim3 step = truth[static_cast<size_t>(i)] * truth[static_cast<size_t>(i - 1)].Inverse();
    graph.cam_from_world.push_back(drift * step * graph.cam_from_world.back());
    graph.fixed.push_back(false);
    graph.edges.push_back({i - 1, i,
                           graph.cam_from_world[static_cast<size_t>(i)] *
                               graph.cam_from_world[static_cast<size_t>(i - 1)].Inverse(),
                           1.0});
  }
  graph.edges.push_back({n - 1, 0, truth[0] * truth[static_cast<size_t>(n - 1)].Inverse(), 10.0});
  auto centre_error = [&](int i) {
    const Eigen::Vector3d c = graph.cam_from_world[static_cast<size_t>(i)].Inverse().translation;
    const Eigen::Vector3d t = truth[static_cast<size_t>(i)].Inverse().translation;
    return (c - t).norm();
  };
  std::vector<double> before;
  for (int i = 0; i < n; ++i) before.push_back(centre_error(i));
  const PoseGraphSummary summary = OptimizePoseGraph({}, &graph);
  ASSERT_TRUE(summary.ran) << summary.message;
  EXPECT_LT(summary.final_cost, 0.1 * summary.initial_cost);
  for (int i = n / 2; i < n; ++i) {
    EXPECT_LT(centre_error(i), 0.5 * before[static_cast<size_t>(i)]) << "camera " << i;
  }
  EXPECT_LT(centre_error(n - 1), 0.1);
  EXPECT_EQ(graph.cam_from_world[0].translation, truth[0].translation);  // Fixed.
}

}  // namespace
}  // namespace mm
