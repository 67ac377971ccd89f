#include "calib/camera_model.h"

#include <gtest/gtest.h>

#include <iostream>
#include <opencv2/calib3d.hpp>
#include <random>

#include "calib/opencv_camera.h"

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

// Analytic Jacobians of Project (w.r.t. point and the 10 intrinsics) and Unproject agree with
// central differences (threshold 1e-6 relative: the central-difference truncation error).
TEST(BouguetCamera, ProjectAndUnprojectJacobiansMatchNumeric) {
  BouguetCamera c = TestCamera();
  c.alpha_c = 0.01;
  c.kc = {-0.25, 0.12, -0.003, 0.002, 0.01};
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> xy(-0.5, 0.5), z(0.5, 3.0);
  for (int i = 0; i < 200; ++i) {
    const Eigen::Vector3d p(xy(rng) * 2, xy(rng) * 2, z(rng));
    Eigen::Matrix<double, 2, 3> jp;
    Eigen::Matrix<double, 2, BouguetCamera::kNumIntrinsics> ji;
    const Eigen::Vector2d pix = c.Project(p, &jp, &ji);
    // Same pixel with and without Jacobians, to rounding: 0 on x86-64; up to 1.6e-12 px on
    // aarch64, where gcc contracts a * b + c into fused multiply-adds differently in the two paths.
    EXPECT_LT((pix - c.Project(p)).norm(), 1e-11);
    for (int j = 0; j < 3; ++j) {
      const double h = 1e-6 * std::max(1.0, std::abs(p[j]));
      Eigen::Vector3d e = Eigen::Vector3d::Zero();
      e[j] = h;
      const Eigen::Vector2d num = (c.Project(p + e) - c.Project(p - e)) / (2 * h);
      EXPECT_LT((num - jp.col(j)).norm(), 1e-6 * std::max(1.0, num.norm())) << "point " << j;
    }
    const BouguetCamera::IntrinsicsVector base = c.Intrinsics();
    for (int j = 0; j < BouguetCamera::kNumIntrinsics; ++j) {
      const double h = 1e-6 * std::max(1.0, std::abs(base[j]));
      BouguetCamera plus = c, minus = c;
      BouguetCamera::IntrinsicsVector bp = base, bm = base;
      bp[j] += h;
      bm[j] -= h;
      plus.SetIntrinsics(bp);
      minus.SetIntrinsics(bm);
      const Eigen::Vector2d num = (plus.Project(p) - minus.Project(p)) / (2 * h);
      EXPECT_LT((num - ji.col(j)).norm(), 1e-6 * std::max(1.0, num.norm())) << "intrinsic " << j;
    }
    // Unproject: d x_n / d pixel.
    Eigen::Matrix2d ju;
    (void)c.Unproject(pix, &ju);
    for (int j = 0; j < 2; ++j) {
      const double h = 1e-4;
      Eigen::Vector2d e = Eigen::Vector2d::Zero();
      e[j] = h;
      const Eigen::Vector2d num = (c.Unproject(pix + e) - c.Unproject(pix - e)) / (2 * h);
      EXPECT_LT((num - ju.col(j)).norm(), 1e-9) << "unproject " << j;
    }
  }
}

// Undistort (iterative inverse) then distort returns every pixel of the image within 0.01 px;
// measured worst 2.5e-13 px for the Bouguet example lens, an EuRoC-like lens and a skewed one.
TEST(BouguetCamera, UndistortThenDistortEveryPixel) {
  BouguetCamera strong = TestCamera();
  strong.fc = {458.654, 457.296};  // EuRoC cam0-like, 752x480.
  strong.cc = {367.215, 248.375};
  strong.kc = {-0.28340811, 0.07395907, 0.00019359, 1.76187114e-05, 0.0};
  strong.width = 752;
  strong.height = 480;
  BouguetCamera skewed = TestCamera();
  skewed.alpha_c = 0.02;
  skewed.kc[4] = 0.05;
  for (const BouguetCamera& c : {TestCamera(), strong, skewed}) {
    double worst = 0.0;
    for (int v = 0; v < c.height; ++v) {
      for (int u = 0; u < c.width; ++u) {
        const Eigen::Vector2d pixel(u, v);
        const Eigen::Vector2d x_n = c.Unproject(pixel);
        const Eigen::Vector2d back = c.Project(Eigen::Vector3d(x_n.x(), x_n.y(), 1.0));
        worst = std::max(worst, (back - pixel).norm());
      }
    }
    std::cout << "undistort->distort worst error " << worst << " px (" << c.width << "x" << c.height
              << ")\n";
    EXPECT_LT(worst, 0.01) << c.width << "x" << c.height;
  }
}

TEST(BouguetCamera, OpenCvConversionRoundTripsAndMatchesProjectPoints) {
  BouguetCamera c = TestCamera();
  OpenCvCamera o = ToOpenCv(c);
  EXPECT_DOUBLE_EQ(o.K(0, 1), c.alpha_c * c.fc.x());
  BouguetCamera back;
  ASSERT_EQ(FromOpenCv(o.K, o.dist, o.size, &back), "");
  EXPECT_EQ(back.fc, c.fc);
  EXPECT_EQ(back.cc, c.cc);
  EXPECT_NEAR(back.alpha_c, c.alpha_c, 1e-18);
  EXPECT_EQ(back.kc, c.kc);
  EXPECT_EQ(back.width, 640);

  // Without skew (OpenCV ignores K(0,1)) cv::projectPoints gives the same pixels: the same model
  // and the same 0-based convention.
  c.alpha_c = 0.0;
  c.kc[4] = 0.02;
  o = ToOpenCv(c);
  std::vector<cv::Point3d> pts;
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> d(-0.5, 0.5);
  for (int i = 0; i < 50; ++i) pts.emplace_back(d(rng), d(rng), 1.0 + d(rng));
  std::vector<cv::Point2d> cv_px;
  cv::projectPoints(pts, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), o.K, o.dist, cv_px);
  for (size_t i = 0; i < pts.size(); ++i) {
    const Eigen::Vector2d px = c.Project(Eigen::Vector3d(pts[i].x, pts[i].y, pts[i].z));
    EXPECT_NEAR(px.x(), cv_px[i].x, 1e-9);
    EXPECT_NEAR(px.y(), cv_px[i].y, 1e-9);
  }

  std::vector<double> eight(8, 0.0);
  eight[5] = 0.1;
  EXPECT_EQ(FromOpenCv(o.K, eight, o.size, &back).rfind("dist", 0), 0u);
  EXPECT_EQ(FromOpenCv(o.K, {0.1, 0.2}, o.size, &back).rfind("dist", 0), 0u);
  cv::Matx33d bad = o.K;
  bad(0, 0) = -1;
  EXPECT_EQ(FromOpenCv(bad, o.dist, o.size, &back).rfind("fc", 0), 0u);
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
