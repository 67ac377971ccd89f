// EstimateViewPose (recon/view_pose.h): the pose of a frame between A and B from the pair's
// points and its correspondences with A, with noise and outliers.
#include "recon/view_pose.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <random>
#include <vector>

namespace mm {
namespace {

struct ViewScene {
  Eigen::Matrix3d K;
  std::vector<Eigen::Vector3d> points;
  std::vector<Eigen::Vector2d> pixels_a;
  Eigen::Matrix3d R;
  Eigen::Vector3d t;
  ViewScene() {
    K << 525, 0, 319.5, 0, 525, 239.5, 0, 0, 1;
    R = Eigen::AngleAxisd(0.03, Eigen::Vector3d(0.2, 1, 0.1).normalized()).toRotationMatrix();
    t = Eigen::Vector3d(-0.3, 0.02, 0.05);
    std::mt19937 rng(11);
    std::uniform_real_distribution<double> u(0, 640), v(0, 480), depth(1.5, 5.0);
    for (int i = 0; i < 300; ++i) {
      const Eigen::Vector2d p(u(rng), v(rng));
      points.push_back(K.inverse() * p.homogeneous() * depth(rng));
      pixels_a.push_back(p);
    }
  }
  Eigen::Vector2d Project(const Eigen::Vector3d& X) const {
    return (K * (R * X + t)).hnormalized();
  }
};

TEST(ViewPose, RecoversThePoseThroughNoiseAndOutliers) {
  const ViewScene s;
  std::mt19937 rng(5);
  std::normal_distribution<double> noise(0, 0.5);
  std::uniform_real_distribution<double> anywhere(0, 480);
  std::vector<Eigen::Vector2d> pixels_a, pixels_view;
  // Every other point is seen in the view, a quarter of those wrongly (a drifted track);
  // and correspondences at pixels of A that are no point at all.
  for (size_t i = 0; i < s.points.size(); i += 2) {
    pixels_a.push_back(s.pixels_a[i]);
    const Eigen::Vector2d noisy = s.Project(s.points[i]) + Eigen::Vector2d(noise(rng), noise(rng));
    pixels_view.push_back(i % 8 == 0 ? Eigen::Vector2d(anywhere(rng), anywhere(rng)) : noisy);
  }
  for (int i = 0; i < 50; ++i) {
    pixels_a.emplace_back(anywhere(rng) + 0.37, anywhere(rng) + 0.41);
    pixels_view.emplace_back(anywhere(rng), anywhere(rng));
  }
  const ViewPose pose =
      EstimateViewPose(s.points, s.pixels_a, pixels_a, pixels_view, s.K, ViewPoseOptions{});
  ASSERT_TRUE(pose.success) << pose.failure_reason;
  EXPECT_EQ(pose.correspondences_on_points, 150);
  const double rotation_deg =
      Eigen::AngleAxisd(pose.rotation_from_a.transpose() * s.R).angle() * 180 / M_PI;
  std::cout << "inliers " << pose.inliers << " of " << pose.correspondences_on_points << ", rms "
            << pose.reprojection_rms_px << " px, rotation off " << rotation_deg
            << " deg, translation off " << (pose.translation_from_a - s.t).norm() << "\n";
  // 38 of the 150 are wrong (every 4th); with 0.5 px noise the other 112 are within 2 px.
  EXPECT_GE(pose.inliers, 110);
  EXPECT_LE(pose.inliers, 112);
  EXPECT_LT(rotation_deg, 0.05);
  EXPECT_LT((pose.translation_from_a - s.t).norm(), 0.01);
  EXPECT_LT(pose.reprojection_rms_px, 1.0);
}

TEST(ViewPose, SaysWhyItHasNoPose) {
  const ViewScene s;
  std::vector<Eigen::Vector2d> pixels_a(s.pixels_a.begin(), s.pixels_a.begin() + 10);
  std::vector<Eigen::Vector2d> pixels_view;
  for (size_t i = 0; i < 10; ++i) pixels_view.push_back(s.Project(s.points[i]));
  ViewPose pose =
      EstimateViewPose(s.points, s.pixels_a, pixels_a, pixels_view, s.K, ViewPoseOptions{});
  EXPECT_FALSE(pose.success);
  EXPECT_NE(pose.failure_reason.find("10 correspondences on the pair's points"), std::string::npos)
      << pose.failure_reason;
  // Unrelated pixels in the view: no consistent pose.
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> anywhere(0, 480);
  pixels_view.clear();
  for (size_t i = 0; i < s.points.size(); ++i)
    pixels_view.emplace_back(anywhere(rng), anywhere(rng));
  pose = EstimateViewPose(s.points, s.pixels_a, s.pixels_a, pixels_view, s.K, ViewPoseOptions{});
  EXPECT_FALSE(pose.success);
  EXPECT_NE(pose.failure_reason.find("PnP inliers of 300"), std::string::npos)
      << pose.failure_reason;
  ViewPoseOptions bad;
  bad.threshold_px = 0;
  EXPECT_FALSE(EstimateViewPose(s.points, s.pixels_a, s.pixels_a, pixels_view, s.K, bad).success);
}

}  // namespace
}  // namespace mm
