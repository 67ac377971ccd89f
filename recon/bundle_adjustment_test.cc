#include "recon/bundle_adjustment.h"

#include <gtest/gtest.h>

#include "dataset/tum.h"
#include "recon/test_scenes.h"

namespace mm {
namespace {

TEST(AdjustTwoViewBundle, RecoversPerturbedPoseAndPoints) {
  const Eigen::Vector3d t_true = Eigen::Vector3d(-0.5, 0.05, 0.1).normalized();
  const auto s = test::MakePair(test::SmallRotation(), t_true, 0.5, 0.0, 21, 300);
  TwoViewBundleProblem p;
  p.k = s.k;
  // Perturb: 1 deg of rotation, 5 deg of translation direction, 5 % noise on the points.
  p.rotation = Eigen::AngleAxisd(1.0 * M_PI / 180, Eigen::Vector3d::UnitZ()) * s.rotation;
  p.translation = (Eigen::AngleAxisd(5.0 * M_PI / 180, Eigen::Vector3d::UnitY()) * t_true);
  std::mt19937 rng(22);
  std::normal_distribution<double> n(0.0, 0.05);
  for (size_t i = 0; i < s.points.size(); ++i) {
    p.points.push_back(s.points[i] * (1.0 + n(rng)));
    p.observations_a.push_back(s.pixels_a[i]);
    p.observations_b.push_back(s.pixels_b[i]);
  }
  const BundleSummary summary = AdjustTwoViewBundle({}, &p);
  ASSERT_TRUE(summary.ran) << summary.message;
  EXPECT_EQ(summary.num_points, 300);
  // Measured: rotation 0.01 deg, direction 0.2 deg, final RMS 0.35 px (noise 0.5 px, Huber).
  EXPECT_LT(RotationErrorDeg(p.rotation, s.rotation), 0.05);
  EXPECT_LT(DirectionErrorDeg(p.translation, t_true), 0.6);
  EXPECT_NEAR(p.translation.norm(), 1.0, 1e-9);  // Stays on the unit sphere.
  EXPECT_LT(summary.final_rms_px, 0.6);
  EXPECT_GT(summary.initial_rms_px, 3.0 * summary.final_rms_px);
  double worst = 0;
  for (size_t i = 0; i < s.points.size(); ++i) {
    worst = std::max(worst, (p.points[i] - s.points[i]).norm() / s.points[i].norm());
  }
  EXPECT_LT(worst, 0.1);
}

TEST(AdjustTwoViewBundle, RefusesTooFewPoints) {
  TwoViewBundleProblem p;
  p.points.resize(3);
  p.observations_a.resize(3);
  p.observations_b.resize(3);
  const BundleSummary summary = AdjustTwoViewBundle({}, &p);
  EXPECT_FALSE(summary.ran);
  EXPECT_FALSE(summary.message.empty());
}

TEST(BundleOptions, Check) {
  BundleOptions o;
  EXPECT_EQ(o.Check(), "");
  o.huber_px = -1;
  EXPECT_EQ(o.Check().rfind("huber_px", 0), 0u);
}

}  // namespace
}  // namespace mm
