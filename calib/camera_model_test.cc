#include "calib/camera_model.h"

#include <gtest/gtest.h>

#include <random>

namespace mm {
namespace {

BouguetCamera TestCamera() {
  BouguetCamera c;
  c.fc = {657.46, 657.94};
  c.cc = {302.99, 242.62};
  c.alpha_c = 0.0012;
  c.kc = {-0.2535, 0.1187, -0.00028, 0.00005, 0.0};
  c.width = 640;
  c.height = 480;
  return c;
}

TEST(BouguetCamera, KHasSkewTerm) {
  const BouguetCamera c = TestCamera();
  const Eigen::Matrix3d k = c.K();
  EXPECT_DOUBLE_EQ(k(0, 1), c.alpha_c * c.fc.x());
  EXPECT_DOUBLE_EQ(k(0, 2), c.cc.x());
  EXPECT_DOUBLE_EQ(k(1, 1), c.fc.y());
}

TEST(BouguetCamera, ProjectUnprojectRoundTrip) {
  const BouguetCamera c = TestCamera();
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(0.0, 640.0), v(0.0, 480.0);
  for (int i = 0; i < 1000; ++i) {
    const Eigen::Vector2d pixel(u(rng), v(rng));
    const Eigen::Vector2d x_n = c.Unproject(pixel);
    const Eigen::Vector2d back = c.Project(Eigen::Vector3d(x_n.x(), x_n.y(), 1.0) * 2.5);
    EXPECT_NEAR((back - pixel).norm(), 0.0, 1e-9) << pixel.transpose();
  }
}

TEST(BouguetCamera, DistortionJacobianMatchesNumeric) {
  BouguetCamera c = TestCamera();
  c.kc = {-0.25, 0.12, -0.003, 0.002, 0.01};
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> d(-0.6, 0.6);
  for (int i = 0; i < 100; ++i) {
    const Eigen::Vector2d x(d(rng), d(rng));
    Eigen::Matrix2d analytic;
    (void)c.Distort(x, &analytic);
    const double h = 1e-7;
    Eigen::Matrix2d numeric;
    for (int j = 0; j < 2; ++j) {
      Eigen::Vector2d e = Eigen::Vector2d::Zero();
      e[j] = h;
      numeric.col(j) = (c.Distort(x + e) - c.Distort(x - e)) / (2 * h);
    }
    EXPECT_LT((analytic - numeric).cwiseAbs().maxCoeff(), 1e-6);
  }
}

TEST(BouguetCamera, CheckNamesBadField) {
  BouguetCamera c = TestCamera();
  c.fc.x() = -1;
  EXPECT_EQ(c.Check().rfind("fc", 0), 0u);
  c = TestCamera();
  c.kc[2] = std::nan("");
  EXPECT_EQ(c.Check().rfind("kc", 0), 0u);
  EXPECT_TRUE(TestCamera().Check().empty());
}

}  // namespace
}  // namespace mm
