#include "map/local_bundle.h"

#include <gtest/gtest.h>

#include "map/background_bundle.h"

#include <algorithm>
#include <random>
#include <stdexcept>
#include <utility>

namespace mm {
namespace {

Eigen::Isometry3d CamFromWorld(double x, double yaw) {
  Eigen::Isometry3d world_from_cam = Eigen::Isometry3d::Identity();
  world_from_cam.linear() = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitY()).toRotationMatrix();
  world_from_cam.translation() = Eigen::Vector3d(x, 0.0, 0.0);
  return world_from_cam.inverse();
}

// Five cameras along x looking at points 3-6 units ahead; two fixed, three perturbed.
struct Scene {
  LocalBundleProblem problem;
  std::vector<Eigen::Isometry3d> truth;
  std::vector<Eigen::Vector3d> points;
};

Scene MakeScene(unsigned seed, double noise_px) {
  Scene s;
  s.problem.k << 500, 0, 320, 0, 500, 240, 0, 0, 1;
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> lateral(-2.0, 2.0), depth(3.0, 6.0);
  std::normal_distribution<double> noise(0.0, noise_px);
  for (int i = 0; i < 5; ++i) s.truth.push_back(CamFromWorld(0.3 * i, 0.02 * i));
  for (int j = 0; j < 200; ++j) s.points.emplace_back(lateral(rng), 0.7 * lateral(rng), depth(rng));
  for (size_t i = 0; i < s.truth.size(); ++i) {
    Eigen::Isometry3d pose = s.truth[i];
    if (i >= 2) {
      pose.translation() += Eigen::Vector3d(0.03, -0.02, 0.04);
      pose.linear() =
          Eigen::AngleAxisd(0.01, Eigen::Vector3d::UnitX()).toRotationMatrix() * pose.linear();
    }
    s.problem.cam_from_world.push_back(pose);
    s.problem.pose_fixed.push_back(i < 2);
  }
  for (size_t j = 0; j < s.points.size(); ++j) {
    s.problem.points_in_world.push_back(s.points[j] + Eigen::Vector3d(0.02, 0.02, -0.05));
    for (size_t i = 0; i < s.truth.size(); ++i) {
      const Eigen::Vector3d x = s.truth[i] * s.points[j];
      const Eigen::Vector2d pixel =
          (s.problem.k * x).hnormalized() + Eigen::Vector2d(noise(rng), noise(rng));
      s.problem.observations.push_back({static_cast<int>(i), static_cast<int>(j), pixel});
    }
  }
  return s;
}

// Largest translation (units) and rotation (rad) error of the free poses.
std::pair<double, double> FreePoseErrors(const Scene& s) {
  double translation = 0.0, rotation = 0.0;
  for (size_t i = 2; i < s.truth.size(); ++i) {
    translation = std::max(
        translation, (s.problem.cam_from_world[i].translation() - s.truth[i].translation()).norm());
    rotation = std::max(rotation, Eigen::AngleAxisd(s.problem.cam_from_world[i].linear() *
                                                    s.truth[i].linear().transpose())
                                      .angle());
  }
  return {translation, rotation};
}

TEST(LocalBundleTest, RecoversTheFreePosesExactlyWithoutNoise) {
  Scene s = MakeScene(7, 0.0);
  const LocalBundleSummary summary = AdjustLocalBundle({}, &s.problem);
  ASSERT_TRUE(summary.ran) << summary.message;
  EXPECT_GT(summary.initial_rms_px, 2.0);  // The perturbation (measured: 2.4 px).
  EXPECT_LT(summary.final_rms_px, 1e-6);
  const auto [translation, rotation] = FreePoseErrors(s);
  // The two fixed poses fix the gauge and the scale, so the free ones come back as they were.
  EXPECT_LT(translation, 1e-6);
  EXPECT_LT(rotation, 1e-6);
  for (int i = 0; i < 2; ++i) {
    EXPECT_TRUE(s.problem.cam_from_world[i].isApprox(s.truth[i], 1e-12)) << "pose " << i;
  }
}

TEST(LocalBundleTest, ReducesThePoseErrorWithNoise) {
  Scene s = MakeScene(7, 0.5);
  const LocalBundleSummary summary = AdjustLocalBundle({}, &s.problem);
  ASSERT_TRUE(summary.ran) << summary.message;
  EXPECT_LT(summary.final_rms_px, 0.8);  // 0.5 px noise per axis.
  const auto [translation, rotation] = FreePoseErrors(s);
  // Perturbed by 0.054 units and 0.01 rad; measured after: 0.009 units, 0.0019 rad.
  EXPECT_LT(translation, 0.02);
  EXPECT_LT(rotation, 0.004);
}

TEST(LocalBundleTest, RefusesMismatchedPoseFlags) {
  Scene s = MakeScene(3, 0.0);
  s.problem.pose_fixed.pop_back();
  EXPECT_FALSE(AdjustLocalBundle({}, &s.problem).ran);
  EXPECT_FALSE(LocalBundleOptions{.huber_px = 0}.Check().empty());
}

// The same adjustment on the background thread: the same result as in the caller's thread
// (Ceres on one thread is deterministic), while the caller's copy stays as it was.
TEST(BackgroundBundleTest, GivesTheCallersResultOnItsOwnCopy) {
  Scene here = MakeScene(7, 0.5);
  const Scene original = MakeScene(7, 0.5);
  BackgroundBundle background;
  EXPECT_FALSE(background.running());
  background.Start({}, original.problem);
  EXPECT_TRUE(background.running());
  const LocalBundleSummary summary = AdjustLocalBundle({}, &here.problem);
  const BackgroundBundleResult result = background.Take();
  EXPECT_FALSE(background.running());
  ASSERT_TRUE(result.summary.ran) << result.summary.message;
  EXPECT_EQ(result.summary.iterations, summary.iterations);
  EXPECT_DOUBLE_EQ(result.summary.final_rms_px, summary.final_rms_px);
  EXPECT_GT(result.cpu_s, 0.0);
  for (size_t i = 0; i < here.problem.cam_from_world.size(); ++i) {
    EXPECT_TRUE(result.problem.cam_from_world[i].isApprox(here.problem.cam_from_world[i], 1e-12))
        << "pose " << i;
  }
  for (size_t j = 0; j < here.problem.points_in_world.size(); ++j) {
    ASSERT_TRUE(result.problem.points_in_world[j].isApprox(here.problem.points_in_world[j], 1e-12))
        << "point " << j;
  }
  EXPECT_FALSE(original.problem.cam_from_world[4].isApprox(result.problem.cam_from_world[4], 1e-6));
}

// A second start waits for the first; a running one is waited for at destruction; Take
// without a start is a programming error.
TEST(BackgroundBundleTest, OneAtATimeAndNoneLeftRunning) {
  const Scene s = MakeScene(3, 0.5);
  {
    BackgroundBundle background;
    background.Start({}, s.problem);
    background.Start({}, s.problem);
    const BackgroundBundleResult result = background.Take();
    EXPECT_TRUE(result.summary.ran);
    background.Start({}, s.problem);  // Left running: the destructor waits for it.
  }
  BackgroundBundle idle;
  EXPECT_FALSE(idle.done());
  EXPECT_THROW(idle.Take(), std::logic_error);
}

}  // namespace
}  // namespace mm
