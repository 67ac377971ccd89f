#include "recon/epipolar.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <iostream>
#include <numbers>

#include "dataset/tum.h"
#include "recon/test_scenes.h"

namespace mm {
namespace {

using test::MakePair;
using test::SmallRotation;

Eigen::Matrix3d Skew(const Eigen::Vector3d& v) {
  Eigen::Matrix3d m;
  m << 0, -v.z(), v.y(), v.z(), 0, -v.x(), -v.y(), v.x(), 0;
  return m;
}

Eigen::Matrix3d TrueF(const test::SyntheticPair& s) {
  const Eigen::Matrix3d k_inv = s.k.inverse();
  const Eigen::Matrix3d f = k_inv.transpose() * Skew(s.translation) * s.rotation * k_inv;
  return f / f.norm();
}

double FDistance(const Eigen::Matrix3d& a, const Eigen::Matrix3d& b) {
  return std::min((a - b).norm(), (a + b).norm());
}

const Eigen::Vector3d kSideways(-0.5, 0.05, 0.1);

TEST(EightPointFundamental, ExactWithoutNoise) {
  const auto s = MakePair(SmallRotation(), kSideways, 0.0, 0.0, 1, 50);
  const auto f = EightPointFundamental(s.pixels_a, s.pixels_b);
  ASSERT_TRUE(f.has_value());
  EXPECT_LT(FDistance(*f, TrueF(s)), 1e-6);
  EXPECT_NEAR(f->determinant(), 0.0, 1e-12);
  for (size_t i = 0; i < s.pixels_a.size(); ++i) {
    EXPECT_LT(SampsonDistanceSq(*f, s.pixels_a[i], s.pixels_b[i]), 1e-12);
  }
}

TEST(EightPointFundamental, RejectsTooFewPoints) {
  const auto s = MakePair(SmallRotation(), kSideways, 0.0, 0.0, 1, 7);
  EXPECT_FALSE(EightPointFundamental(s.pixels_a, s.pixels_b).has_value());
}

TEST(SampsonDistance, MatchesPerpendicularOffsetFromEpipolarLine) {
  const auto s = MakePair(SmallRotation(), kSideways, 0.0, 0.0, 2, 10);
  const Eigen::Matrix3d f = TrueF(s);
  // Move b by 0.7 px along the normal of its epipolar line: Sampson ~ 0.7 px (first order;
  // the term from a's own line makes it a bit smaller).
  const Eigen::Vector3d line = f * s.pixels_a[0].homogeneous();
  const Eigen::Vector2d normal = line.head<2>().normalized();
  const double d = std::sqrt(SampsonDistanceSq(f, s.pixels_a[0], s.pixels_b[0] + 0.7 * normal));
  EXPECT_GT(d, 0.4);
  EXPECT_LT(d, 0.71);
}

TEST(RansacFundamental, FindsInliersWithNoiseAndOutliers) {
  const auto s = MakePair(SmallRotation(), kSideways, 0.5, 0.3, 3, 500);
  RansacOptions o;
  o.threshold_px = 1.5;
  const RansacResult r = RansacFundamental(s.pixels_a, s.pixels_b, o);
  ASSERT_TRUE(r.success) << r.failure_reason;
  int true_inliers = 0, outliers_taken = 0;
  for (bool out : s.is_outlier) true_inliers += out ? 0 : 1;
  for (int i : r.inliers) outliers_taken += s.is_outlier[static_cast<size_t>(i)] ? 1 : 0;
  // Measured (seed 3): 338 of 347 true inliers taken, 3 outliers by chance near their line.
  EXPECT_GT(static_cast<int>(r.inliers.size()) - outliers_taken, 0.93 * true_inliers);
  EXPECT_LT(outliers_taken, 10);
  EXPECT_LE(r.iterations, o.max_iterations);
  EXPECT_GT(r.iterations, 50);  // 30 % outliers, 8-point samples: ~150-200 needed.
  // The refined F is close to the truth: pose from it within a fraction of a degree.
  const Eigen::Matrix3d e = EssentialFromFundamental(r.model, s.k);
  std::vector<Eigen::Vector2d> na, nb;
  for (size_t i = 0; i < s.pixels_a.size(); ++i) {
    na.push_back((s.k.inverse() * s.pixels_a[i].homogeneous()).hnormalized());
    nb.push_back((s.k.inverse() * s.pixels_b[i].homogeneous()).hnormalized());
  }
  const CheiralityResult c = SelectPoseByCheirality(e, na, nb, r.inliers, {});
  ASSERT_TRUE(c.success) << c.failure_reason;
  EXPECT_LT(RotationErrorDeg(c.pose.rotation, s.rotation), 0.3);
  EXPECT_LT(DirectionErrorDeg(c.pose.translation, s.translation), 2.0);
}

TEST(RansacFundamental, AdaptiveIterationsAndSeed) {
  const auto clean = MakePair(SmallRotation(), kSideways, 0.3, 0.0, 4, 300);
  RansacOptions o;
  const RansacResult r_clean = RansacFundamental(clean.pixels_a, clean.pixels_b, o);
  ASSERT_TRUE(r_clean.success);
  // No outliers: the adaptive bound drops to a handful, so only min_iterations are drawn.
  EXPECT_EQ(r_clean.iterations, o.min_iterations);
  const auto dirty = MakePair(SmallRotation(), kSideways, 0.3, 0.5, 4, 300);
  const RansacResult r1 = RansacFundamental(dirty.pixels_a, dirty.pixels_b, o);
  const RansacResult r2 = RansacFundamental(dirty.pixels_a, dirty.pixels_b, o);
  ASSERT_TRUE(r1.success);
  EXPECT_GT(r1.iterations, 1000);  // 50 % outliers: (1 - 0.5^8) needs ~2400 for 0.9999.
  EXPECT_EQ(r1.iterations, r2.iterations);
  EXPECT_EQ(r1.inliers, r2.inliers);
  EXPECT_EQ(r1.model, r2.model);
}

// LO-RANSAC (Chum et al. 2003) against plain RANSAC on the same synthetic scene (0.7 px noise,
// 40 % outliers), both without the final LM so the local optimization alone is compared:
// over ten seeds LO keeps more true inliers, its pose error is smaller and less spread, it
// stops earlier (the adaptive bound sees the larger inlier count), and it is deterministic.
TEST(RansacFundamental, LocalOptimizationIsMoreAccurateAndStable) {
  // 30 % outliers, 99 % confidence, at most 1000 samples, 400 points: small enough for the
  // ASan (Debug) stage.
  const auto s = MakePair(SmallRotation(), kSideways, 0.7, 0.3, 11, 400);
  std::vector<Eigen::Vector2d> na, nb;
  for (size_t i = 0; i < s.pixels_a.size(); ++i) {
    na.push_back((s.k.inverse() * s.pixels_a[i].homogeneous()).hnormalized());
    nb.push_back((s.k.inverse() * s.pixels_b[i].homogeneous()).hnormalized());
  }
  struct Stats {
    double rot_sum = 0, rot_max = 0, trans_sum = 0;
    int true_inliers = 0, iterations = 0;
  };
  auto run = [&](bool lo) {
    Stats st;
    for (unsigned seed = 1; seed <= 10; ++seed) {
      RansacOptions o;
      o.seed = seed;
      o.confidence = 0.99;
      o.max_iterations = 1000;
      o.refine_iterations = 0;
      o.local_optimization = lo;
      const RansacResult r = RansacFundamental(s.pixels_a, s.pixels_b, o);
      EXPECT_TRUE(r.success) << r.failure_reason;
      if (lo) {
        EXPECT_GE(r.local_optimizations, 1);
        EXPECT_GE(r.local_improvements, 1);
      } else {
        EXPECT_EQ(r.local_optimizations, 0);
      }
      for (int i : r.inliers) st.true_inliers += s.is_outlier[static_cast<size_t>(i)] ? 0 : 1;
      st.iterations += r.iterations;
      const CheiralityResult c = SelectPoseByCheirality(
          EssentialFromFundamental(r.model, s.k), na, nb, r.inliers, {});
      EXPECT_TRUE(c.success) << c.failure_reason;
      const double rot = RotationErrorDeg(c.pose.rotation, s.rotation);
      st.rot_sum += rot;
      st.rot_max = std::max(st.rot_max, rot);
      st.trans_sum += DirectionErrorDeg(c.pose.translation, s.translation);
    }
    return st;
  };
  const Stats plain = run(false), lo = run(true);
  std::cout << "plain: rot mean " << plain.rot_sum / 10 << " max " << plain.rot_max
            << " trans mean " << plain.trans_sum / 10 << " true inliers " << plain.true_inliers
            << " iterations " << plain.iterations << "\nLO:    rot mean " << lo.rot_sum / 10
            << " max " << lo.rot_max << " trans mean " << lo.trans_sum / 10 << " true inliers "
            << lo.true_inliers << " iterations " << lo.iterations << "\n";
  EXPECT_GT(lo.true_inliers, plain.true_inliers);
  EXPECT_LT(lo.rot_sum, plain.rot_sum);
  EXPECT_LT(lo.rot_max, plain.rot_max);
  EXPECT_LT(lo.trans_sum, plain.trans_sum);
  EXPECT_LT(lo.iterations, plain.iterations);

  RansacOptions o;
  o.local_optimization = true;
  o.seed = 3;
  const RansacResult r1 = RansacFundamental(s.pixels_a, s.pixels_b, o);
  const RansacResult r2 = RansacFundamental(s.pixels_a, s.pixels_b, o);
  EXPECT_EQ(r1.model, r2.model);
  EXPECT_EQ(r1.inliers, r2.inliers);
  EXPECT_EQ(r1.iterations, r2.iterations);
}

TEST(RefineFundamentalSampson, ReducesSampsonError) {
  const auto s = MakePair(SmallRotation(), kSideways, 1.0, 0.0, 5, 200);
  std::vector<int> all(s.pixels_a.size());
  for (size_t i = 0; i < all.size(); ++i) all[i] = static_cast<int>(i);
  // Start from an 8-point fit on 8 points only: biased; LM on all must reduce the cost.
  const std::vector<Eigen::Vector2d> a8(s.pixels_a.begin(), s.pixels_a.begin() + 8);
  const std::vector<Eigen::Vector2d> b8(s.pixels_b.begin(), s.pixels_b.begin() + 8);
  const auto f0 = EightPointFundamental(a8, b8);
  ASSERT_TRUE(f0.has_value());
  auto cost = [&](const Eigen::Matrix3d& f) {
    double c = 0;
    for (size_t i = 0; i < s.pixels_a.size(); ++i) c += SampsonDistanceSq(f, s.pixels_a[i], s.pixels_b[i]);
    return c / static_cast<double>(s.pixels_a.size());
  };
  const Eigen::Matrix3d f1 = RefineFundamentalSampson(*f0, s.pixels_a, s.pixels_b, all, 30);
  EXPECT_LT(cost(f1), cost(*f0));
  // With sigma = 1 px per coordinate the mean squared Sampson residual is ~ sigma^2 (1 dof).
  EXPECT_LT(cost(f1), 1.3);
  EXPECT_NEAR(f1.determinant(), 0.0, 1e-10);
}

TEST(RansacHomography, RecoversPlaneInducedHomography) {
  const auto s = MakePair(SmallRotation(), kSideways, 0.5, 0.2, 6, 300, test::SceneShape::kPlane);
  RansacOptions o;
  o.threshold_px = ClassifyOptions{}.homography_threshold_px;
  const RansacResult r = RansacHomography(s.pixels_a, s.pixels_b, o);
  ASSERT_TRUE(r.success) << r.failure_reason;
  // Noise-free transfer of the true points through the estimate (both directions summed):
  // measured worst 0.35 px with 0.5 px noise (seed 6).
  const Eigen::Matrix3d h_inv = r.model.inverse();
  double worst = 0;
  for (size_t i = 0; i < s.points.size(); ++i) {
    const Eigen::Vector2d a = (s.k * s.points[i]).hnormalized();
    const Eigen::Vector2d b = (s.k * (s.rotation * s.points[i] + s.translation)).hnormalized();
    worst = std::max(worst, SymmetricTransferErrorSq(r.model, h_inv, a, b));
  }
  std::cout << "worst symmetric transfer error " << std::sqrt(worst) << " px\n";
  EXPECT_LT(std::sqrt(worst), 1.0);
  int outliers_taken = 0;
  for (int i : r.inliers) outliers_taken += s.is_outlier[static_cast<size_t>(i)] ? 1 : 0;
  EXPECT_LT(outliers_taken, 5);
}

TEST(EssentialFromFundamental, ProjectsToEssentialManifold) {
  const auto s = MakePair(SmallRotation(), kSideways, 1.0, 0.0, 7, 100);
  const auto f = EightPointFundamental(s.pixels_a, s.pixels_b);
  ASSERT_TRUE(f.has_value());
  const Eigen::Matrix3d e = EssentialFromFundamental(*f, s.k);
  const Eigen::Vector3d sv = Eigen::JacobiSVD<Eigen::Matrix3d>(e).singularValues();
  EXPECT_NEAR(sv[0], sv[1], 1e-12);
  EXPECT_NEAR(sv[2], 0.0, 1e-12);
  // 2 E E^T E - trace(E E^T) E = 0 (H&Z eq. 9.14 / Demazure).
  EXPECT_LT((2 * e * e.transpose() * e - (e * e.transpose()).trace() * e).norm(), 1e-12);
}

TEST(DecomposeEssential, OneOfFourIsTheTruePose) {
  const Eigen::Vector3d t = kSideways.normalized();
  const Eigen::Matrix3d e = Skew(t) * SmallRotation();
  int found = 0;
  for (const RelativePose& p : DecomposeEssential(e)) {
    EXPECT_NEAR(p.rotation.determinant(), 1.0, 1e-12);
    if (RotationErrorDeg(p.rotation, SmallRotation()) < 1e-6 &&
        DirectionErrorDeg(p.translation, t) < 1e-6) {
      ++found;
    }
  }
  EXPECT_EQ(found, 1);
}

TEST(SelectPoseByCheirality, RejectsWithoutClearWinner) {
  const auto s = MakePair(SmallRotation(), kSideways, 0.0, 0.0, 8, 200);
  const Eigen::Matrix3d e = Skew(kSideways.normalized()) * SmallRotation();
  std::vector<Eigen::Vector2d> na, nb;
  std::vector<int> all;
  for (size_t i = 0; i < s.points.size(); ++i) {
    // Half of the points mirrored through A's centre: behind both cameras under the true pose,
    // in front of both under (R, -t): the two candidates tie.
    const Eigen::Vector3d p = (i % 2 == 0) ? s.points[i] : Eigen::Vector3d(-s.points[i]);
    na.push_back(p.hnormalized());
    nb.push_back((s.rotation * p + s.translation).hnormalized());
    all.push_back(static_cast<int>(i));
  }
  const CheiralityResult tie = SelectPoseByCheirality(e, na, nb, all, {});
  EXPECT_FALSE(tie.success);
  EXPECT_NE(tie.failure_reason.find("clear winner"), std::string::npos) << tie.failure_reason;
  // Only the points in front: a clear winner, the true pose.
  std::vector<int> front;
  for (size_t i = 0; i < all.size(); i += 2) front.push_back(static_cast<int>(i));
  const CheiralityResult ok = SelectPoseByCheirality(e, na, nb, front, {});
  ASSERT_TRUE(ok.success) << ok.failure_reason;
  EXPECT_LT(RotationErrorDeg(ok.pose.rotation, s.rotation), 1e-6);
  EXPECT_LT(DirectionErrorDeg(ok.pose.translation, s.translation), 1e-6);
  EXPECT_EQ(ok.in_front[static_cast<size_t>(ok.winner)], static_cast<int>(front.size()));
}

TEST(Triangulation, LinearExactThenRefinedReducesReprojection) {
  const RelativePose pose{SmallRotation(), kSideways.normalized()};
  const Eigen::Vector3d p(0.3, -0.2, 4.0);
  const Eigen::Vector3d pb = pose.rotation * p + pose.translation;
  EXPECT_LT((TriangulateLinear(p.hnormalized(), pb.hnormalized(), pose) - p).norm(), 1e-9);
  std::mt19937 rng(9);
  std::normal_distribution<double> noise(0.0, 1.0 / 500);  // ~1 px at f = 500
  double sum_linear = 0, sum_refined = 0;
  for (int k = 0; k < 200; ++k) {
    const Eigen::Vector2d xa = p.hnormalized() + Eigen::Vector2d(noise(rng), noise(rng));
    const Eigen::Vector2d xb = pb.hnormalized() + Eigen::Vector2d(noise(rng), noise(rng));
    auto reproj = [&](const Eigen::Vector3d& q) {
      return (q.hnormalized() - xa).squaredNorm() +
             ((pose.rotation * q + pose.translation).hnormalized() - xb).squaredNorm();
    };
    const Eigen::Vector3d lin = TriangulateLinear(xa, xb, pose);
    const Eigen::Vector3d ref = RefineTriangulation(lin, xa, xb, pose);
    EXPECT_LE(reproj(ref), reproj(lin) * (1 + 1e-9));
    sum_linear += reproj(lin);
    sum_refined += reproj(ref);
  }
  EXPECT_LT(sum_refined, sum_linear);
  EXPECT_NEAR(TriangulationAngleDeg(p, pose),
              std::acos(p.normalized().dot((p + pose.rotation.transpose() * pose.translation)
                                               .normalized())) * 180 / std::numbers::pi,
              1e-9);
}

TEST(ClassifyPair, GeneralPlanarRotationAndNoParallax) {
  RansacOptions o;
  auto classify = [&](const test::SyntheticPair& s) {
    const RansacResult f = RansacFundamental(s.pixels_a, s.pixels_b, o);
    RansacOptions oh = o;
    oh.threshold_px = ClassifyOptions{}.homography_threshold_px;
    const RansacResult h = RansacHomography(s.pixels_a, s.pixels_b, oh);
    return ClassifyPair(s.pixels_a, s.pixels_b, f, h, s.k, {});
  };
  const auto general = MakePair(SmallRotation(), kSideways, 0.5, 0.1, 10);
  EXPECT_EQ(classify(general).kind, PairKind::kGeneral);
  const auto planar =
      MakePair(SmallRotation(), kSideways, 0.5, 0.1, 11, 400, test::SceneShape::kPlane);
  const PairClassification p = classify(planar);
  EXPECT_EQ(p.kind, PairKind::kPlanar) << p.h_share << " " << p.rotation_deviation;
  const auto rotation = MakePair(SmallRotation(), Eigen::Vector3d::Zero(), 0.5, 0.1, 12);
  const PairClassification r = classify(rotation);
  EXPECT_EQ(r.kind, PairKind::kRotation) << r.h_share << " " << r.rotation_deviation;
  const auto still = MakePair(Eigen::Matrix3d::Identity(), Eigen::Vector3d::Zero(), 0.3, 0.0, 13);
  EXPECT_EQ(classify(still).kind, PairKind::kNoParallax);
}

}  // namespace
}  // namespace mm
