#include "recon/two_view.h"

#include <gtest/gtest.h>

#include "dataset/tum.h"
#include "recon/test_scenes.h"

namespace mm {
namespace {

using test::MakePair;
using test::SmallRotation;

TEST(EstimateTwoView, RecoversPoseAndPointsWithNoiseAndOutliers) {
  const auto s = MakePair(SmallRotation(), Eigen::Vector3d(-0.5, 0.05, 0.1), 0.5, 0.25, 1);
  const TwoViewResult r = EstimateTwoView(s.pixels_a, s.pixels_b, s.k, {});
  ASSERT_TRUE(r.success) << r.failure_reason;
  EXPECT_EQ(r.classification.kind, PairKind::kGeneral);
  // Measured (seed 1, 0.5 px noise, 25 % outliers): rotation ~0.02 deg, direction ~0.3 deg.
  EXPECT_LT(RotationErrorDeg(r.rotation, s.rotation), 0.1);
  EXPECT_LT(DirectionErrorDeg(r.translation, s.translation), 1.0);
  EXPECT_NEAR(r.translation.norm(), 1.0, 1e-9);
  EXPECT_TRUE(r.bundle.ran);
  EXPECT_LE(r.bundle.final_rms_px, r.bundle.initial_rms_px + 1e-9);
  EXPECT_GT(r.points_in_cam_a.size(), 200u);
  EXPECT_LT(r.reprojection_rms_px, 1.0);
  // Points match the truth after the scale |t_true| (baseline = 1 in the result).
  const double scale = s.translation.norm();
  std::vector<double> rel;
  int outliers_kept = 0;
  for (size_t k = 0; k < r.points_in_cam_a.size(); ++k) {
    const auto i = static_cast<size_t>(r.point_correspondence[k]);
    outliers_kept += s.is_outlier[i] ? 1 : 0;
    if (!s.is_outlier[i]) {
      rel.push_back((scale * r.points_in_cam_a[k] - s.points[i]).norm() / s.points[i].norm());
    }
  }
  EXPECT_LT(MedianOf(rel), 0.02);
  EXPECT_LT(outliers_kept, 5);
  EXPECT_GT(r.median_triangulation_angle_deg, 3.0);
}

TEST(EstimateTwoView, PureRotationIsReportedNotReconstructed) {
  const auto s = MakePair(SmallRotation(), Eigen::Vector3d::Zero(), 0.5, 0.1, 2);
  const TwoViewResult r = EstimateTwoView(s.pixels_a, s.pixels_b, s.k, {});
  EXPECT_FALSE(r.success);
  EXPECT_EQ(r.classification.kind, PairKind::kRotation) << r.failure_reason;
  EXPECT_NE(r.failure_reason.find("rotation"), std::string::npos);
}

TEST(EstimateTwoView, TinyBaselineFailsTheParallaxGate) {
  // 1 cm baseline at 2-6 m: triangulation angles ~0.2 deg, far below the 1 deg gate.
  const auto s = MakePair(SmallRotation(), Eigen::Vector3d(-0.01, 0.0, 0.0), 0.2, 0.0, 3);
  const TwoViewResult r = EstimateTwoView(s.pixels_a, s.pixels_b, s.k, {});
  EXPECT_FALSE(r.success);
  EXPECT_TRUE(r.classification.kind == PairKind::kNoParallax ||
              r.classification.kind == PairKind::kRotation)
      << PairKindName(r.classification.kind) << ": " << r.failure_reason;
}

// A wall seen with translation and a few things off it (400 points on the plane, 40 in the
// volume): H explains > 85 %, F is ill-conditioned, the pose comes from H's decomposition (the
// points off the plane break its twofold ambiguity) and is as accurate as for a general scene.
TEST(EstimateTwoView, PlanarSceneTakesItsPoseFromTheHomography) {
  auto s = MakePair(SmallRotation(), Eigen::Vector3d(-0.5, 0.05, 0.1), 0.5, 0.05, 4, 400,
                    test::SceneShape::kPlane);
  const auto off_plane =
      MakePair(SmallRotation(), Eigen::Vector3d(-0.5, 0.05, 0.1), 0.5, 0.0, 5, 40);
  s.pixels_a.insert(s.pixels_a.end(), off_plane.pixels_a.begin(), off_plane.pixels_a.end());
  s.pixels_b.insert(s.pixels_b.end(), off_plane.pixels_b.begin(), off_plane.pixels_b.end());
  const TwoViewResult r = EstimateTwoView(s.pixels_a, s.pixels_b, s.k, {});
  ASSERT_TRUE(r.success) << r.failure_reason;
  EXPECT_EQ(r.classification.kind, PairKind::kPlanar);
  EXPECT_LT(RotationErrorDeg(r.rotation, s.rotation), 0.2);
  EXPECT_LT(DirectionErrorDeg(r.translation, s.translation), 2.0);
  EXPECT_GT(r.points_in_cam_a.size(), 200u);

  TwoViewOptions refuse;
  refuse.planar_from_h = false;
  const TwoViewResult refused = EstimateTwoView(s.pixels_a, s.pixels_b, s.k, refuse);
  EXPECT_FALSE(refused.success);
  EXPECT_EQ(refused.failure, TwoViewFailure::kPlanar) << refused.failure_reason;
}

TEST(EstimateTwoView, TooFewMatchesFail) {
  const auto s = MakePair(SmallRotation(), Eigen::Vector3d(-0.5, 0, 0), 0.5, 0.0, 4, 20);
  const TwoViewResult r = EstimateTwoView(s.pixels_a, s.pixels_b, s.k, {});
  EXPECT_FALSE(r.success);
  EXPECT_NE(r.failure_reason.find("too few"), std::string::npos);
}

TEST(TwoViewOptions, CheckNamesTheField) {
  TwoViewOptions o;
  EXPECT_EQ(o.Check(), "");
  o.ransac_threshold_px = 0;
  EXPECT_EQ(o.Check().rfind("ransac_threshold_px", 0), 0u);
}

}  // namespace
}  // namespace mm
