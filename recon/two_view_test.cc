#include "recon/two_view.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <numbers>
#include <random>

namespace mm {
namespace {

double AngleDeg(const Eigen::Matrix3d& r) {
  return Eigen::AngleAxisd(r).angle() * 180.0 / std::numbers::pi;
}

struct Scene {
  Eigen::Matrix3d K;
  Eigen::Matrix3d rotation;
  Eigen::Vector3d translation;
  std::vector<Eigen::Vector2d> pixels_a, pixels_b;
};

// Points 2-6 units in front of camera A; camera B moved by `translation` and rotated.
Scene MakeScene(const Eigen::Vector3d& translation, double noise_px, double outlier_share,
                unsigned seed) {
  Scene s;
  s.K << 500, 0, 320, 0, 500, 240, 0, 0, 1;
  s.rotation = (Eigen::AngleAxisd(0.05, Eigen::Vector3d::UnitY()) *
                Eigen::AngleAxisd(-0.02, Eigen::Vector3d::UnitX()))
                   .toRotationMatrix();
  s.translation = translation;
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> lateral(-2.0, 2.0), depth(2.0, 6.0), pix(0, 640);
  std::normal_distribution<double> noise(0.0, noise_px);
  std::bernoulli_distribution outlier(outlier_share);
  while (s.pixels_a.size() < 400) {
    const Eigen::Vector3d p(lateral(rng), lateral(rng) * 0.75, depth(rng));
    const Eigen::Vector3d p_b = s.rotation * p + s.translation;
    const Eigen::Vector2d a = (s.K * p).hnormalized();
    const Eigen::Vector2d b = (s.K * p_b).hnormalized();
    if (a.x() < 0 || a.x() > 640 || a.y() < 0 || a.y() > 480) continue;
    if (b.x() < 0 || b.x() > 640 || b.y() < 0 || b.y() > 480) continue;
    s.pixels_a.push_back(a + Eigen::Vector2d(noise(rng), noise(rng)));
    s.pixels_b.push_back(outlier(rng) ? Eigen::Vector2d(pix(rng), pix(rng) * 0.75)
                                      : b + Eigen::Vector2d(noise(rng), noise(rng)));
  }
  return s;
}

TEST(TriangulateDlt, ExactWithoutNoise) {
  const Eigen::Matrix3d r = Eigen::AngleAxisd(0.1, Eigen::Vector3d::UnitY()).toRotationMatrix();
  const Eigen::Vector3d t(-1, 0.1, 0.05);
  const Eigen::Vector3d p(0.3, -0.2, 4.0);
  const Eigen::Vector3d p_b = r * p + t;
  const Eigen::Vector3d q = TriangulateDlt(p.hnormalized(), p_b.hnormalized(), r, t);
  EXPECT_LT((q - p).norm(), 1e-9);
}

TEST(EstimateTwoView, RecoversPoseWithNoiseAndOutliers) {
  const Scene s = MakeScene(Eigen::Vector3d(-0.5, 0.05, 0.1), 0.5, 0.2, 1);
  const TwoViewResult r = EstimateTwoView(s.pixels_a, s.pixels_b, s.K, TwoViewOptions{});
  ASSERT_TRUE(r.success) << r.failure_reason;
  EXPECT_LT(AngleDeg(r.rotation.transpose() * s.rotation), 0.5);  // Measured 0.25 deg.
  EXPECT_LT(std::acos(r.translation.dot(s.translation.normalized())) * 180 / std::numbers::pi,
            2.0);
  EXPECT_GT(r.num_inliers, 250);
  EXPECT_LT(r.reprojection_rms_px, 1.5);
  // Up to scale: the triangulated depths match the truth after one scale factor.
  const double scale = s.translation.norm();
  int checked = 0;
  for (size_t k = 0; k < r.points_in_cam_a.size(); ++k) {
    const Eigen::Vector2d& px = s.pixels_a[static_cast<size_t>(r.point_correspondence[k])];
    EXPECT_GT(r.points_in_cam_a[k].z() * scale, 1.5) << px.transpose();
    ++checked;
  }
  EXPECT_GT(checked, 200);
}

TEST(EstimateTwoView, ExactWithoutNoise) {
  const Scene s = MakeScene(Eigen::Vector3d(-0.5, 0.05, 0.1), 0.0, 0.2, 4);
  const TwoViewResult r = EstimateTwoView(s.pixels_a, s.pixels_b, s.K, TwoViewOptions{});
  ASSERT_TRUE(r.success) << r.failure_reason;
  EXPECT_LT(AngleDeg(r.rotation.transpose() * s.rotation), 1e-4);
  EXPECT_LT(std::acos(std::min(1.0, r.translation.dot(s.translation.normalized()))) * 180 /
                std::numbers::pi,
            1e-3);
  EXPECT_LT(r.reprojection_rms_px, 1e-3);
}

TEST(EstimateTwoView, SameSeedSameResult) {
  const Scene s = MakeScene(Eigen::Vector3d(0.4, 0.0, 0.2), 0.7, 0.3, 5);
  const TwoViewResult a = EstimateTwoView(s.pixels_a, s.pixels_b, s.K, TwoViewOptions{});
  const TwoViewResult b = EstimateTwoView(s.pixels_a, s.pixels_b, s.K, TwoViewOptions{});
  EXPECT_EQ(a.num_inliers, b.num_inliers);
  EXPECT_EQ(a.rotation, b.rotation);
}

TEST(EstimateTwoView, PureRotationIsTooLittleParallax) {
  const Scene s = MakeScene(Eigen::Vector3d(0, 0, 0), 0.3, 0.0, 2);
  const TwoViewResult r = EstimateTwoView(s.pixels_a, s.pixels_b, s.K, TwoViewOptions{});
  EXPECT_FALSE(r.success);
  EXPECT_FALSE(r.failure_reason.empty());
}

TEST(EstimateTwoView, TooFewMatchesFailsWithReason) {
  const Scene s = MakeScene(Eigen::Vector3d(-0.5, 0, 0), 0.1, 0.0, 3);
  const std::vector<Eigen::Vector2d> a(s.pixels_a.begin(), s.pixels_a.begin() + 10);
  const std::vector<Eigen::Vector2d> b(s.pixels_b.begin(), s.pixels_b.begin() + 10);
  const TwoViewResult r = EstimateTwoView(a, b, s.K, TwoViewOptions{});
  EXPECT_FALSE(r.success);
  EXPECT_NE(r.failure_reason.find("too few matches"), std::string::npos);
}

}  // namespace
}  // namespace mm
