// The sweep's warp (recon/plane_warp.h): against bilinear sampling in double precision at the
// exact positions, against OpenCV's warpPerspective (which rounds positions to 1/32 px), and
// equal to its scalar reference on every Highway target compiled in.

#include "recon/plane_warp.h"

#include <gtest/gtest.h>

#include <hwy/highway.h>
#include <hwy/targets.h>
#include <Eigen/Geometry>
#include <cmath>
#include <iostream>
#include <opencv2/core/eigen.hpp>
#include <opencv2/imgproc.hpp>
#include <random>
#include <vector>

namespace mm {
namespace {

// A smooth random image (noise blurred, so bilinear interpolation is meaningful).
cv::Mat Image(int width, int height, uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> grey(0, 255);
  cv::Mat image(height, width, CV_32F);
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) image.at<float>(y, x) = grey(rng);
  }
  cv::GaussianBlur(image, image, cv::Size(5, 5), 1.5);
  return image;
}

// A plane's homography as the sweep builds it: K (R + t rho e3^T) K^-1 of A's pixel.
Eigen::Matrix3d SweepHomography(int width, int height, double rho) {
  Eigen::Matrix3d K;
  K << 0.8 * width, 0, 0.5 * (width - 1), 0, 0.8 * width, 0.5 * (height - 1), 0, 0, 1;
  const Eigen::Matrix3d R =
      Eigen::AngleAxisd(0.03, Eigen::Vector3d(0.2, 1, 0.1).normalized()).toRotationMatrix();
  const Eigen::Vector3d t(-0.12, 0.02, 0.05);
  Eigen::Matrix3d M = R;
  M.col(2) += rho * t;
  return K * M * K.inverse();
}

double Clamp(double v, double hi) { return std::min(std::max(v, 0.0), hi); }

// Bilinear with replicated borders, in double at the exact position.
double SampleAt(const cv::Mat& view, const Eigen::Matrix3d& H, int x, int y) {
  const Eigen::Vector3d h = H * Eigen::Vector3d(x, y, 1);
  if (!(h.z() > 1e-6)) return view.at<float>(0, 0);
  const double u = Clamp(h.x() / h.z(), view.cols - 1), v = Clamp(h.y() / h.z(), view.rows - 1);
  const int x0 = static_cast<int>(std::floor(u)), y0 = static_cast<int>(std::floor(v));
  const int x1 = std::min(x0 + 1, view.cols - 1), y1 = std::min(y0 + 1, view.rows - 1);
  const double ax = u - x0, ay = v - y0;
  const double top = (1 - ax) * view.at<float>(y0, x0) + ax * view.at<float>(y0, x1);
  const double bottom = (1 - ax) * view.at<float>(y1, x0) + ax * view.at<float>(y1, x1);
  return (1 - ay) * top + ay * bottom;
}

std::span<const float> Span(const cv::Mat& m) { return {m.ptr<float>(), m.total()}; }

TEST(WarpByHomography, IsBilinearAtTheExactPositionWithBordersReplicated) {
  const int width = 96, height = 72;
  const cv::Mat view = Image(width, height, 3);
  // Near and far planes: at rho 2 much of A maps outside the view (replicated borders).
  for (const double rho : {0.2, 2.0}) {
    const Eigen::Matrix3d H = SweepHomography(width, height, rho);
    std::vector<float> out(view.total());
    ASSERT_TRUE(WarpByHomographyScalar(Span(view), width, height, H, out));
    double worst = 0;
    int outside = 0;
    for (int y = 0; y < height; ++y) {
      for (int x = 0; x < width; ++x) {
        const Eigen::Vector3d h = H * Eigen::Vector3d(x, y, 1);
        outside += h.x() / h.z() < 0 || h.x() / h.z() > width - 1;
        worst = std::max(
            worst, std::abs(out[static_cast<size_t>(y) * width + x] - SampleAt(view, H, x, y)));
      }
    }
    std::cout << "rho " << rho << ": " << outside << " pixels outside, worst difference " << worst
              << "\n";
    // float positions: about 1e-5 px at these sizes.
    EXPECT_LT(worst, 0.01) << "rho " << rho;
    if (rho > 1) {
      EXPECT_GT(outside, 100);
    }
  }
}

TEST(WarpByHomography, AgreesWithOpenCvToItsSubPixelRounding) {
  const int width = 320, height = 240;
  const cv::Mat view = Image(width, height, 5);
  const Eigen::Matrix3d H = SweepHomography(width, height, 0.5);
  std::vector<float> out(view.total());
  ASSERT_TRUE(WarpByHomography(Span(view), width, height, H, out));
  cv::Mat Hcv, reference;
  cv::eigen2cv(H, Hcv);
  cv::warpPerspective(view, reference, Hcv, view.size(), cv::INTER_LINEAR | cv::WARP_INVERSE_MAP,
                      cv::BORDER_REPLICATE);
  double sum = 0, worst = 0;
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      const double d =
          std::abs(out[static_cast<size_t>(y) * width + x] - reference.at<float>(y, x));
      sum += d;
      worst = std::max(worst, d);
    }
  }
  const double mean = sum / static_cast<double>(view.total());
  std::cout << "against cv::warpPerspective: mean " << mean << ", worst " << worst << "\n";
  // 1/64 px of position error times the image's gradient (a few grey levels per pixel).
  EXPECT_LT(mean, 0.2);
  EXPECT_LT(worst, 2.0);
}

TEST(WarpByHomography, EqualsScalarReferenceOnEveryCompiledTarget) {
  for (const int width : {37, 320}) {  // 37: every vector width leaves a tail.
    const int height = 29;
    const cv::Mat view = Image(width, height, 11);
    for (const double rho : {0.1, 1.0, 3.0}) {
      const Eigen::Matrix3d H = SweepHomography(width, height, rho);
      std::vector<float> reference(view.total());
      ASSERT_TRUE(WarpByHomographyScalar(Span(view), width, height, H, reference));
      int ran = 0;
      for (const int64_t target : hwy::SupportedAndGeneratedTargets()) {
        hwy::SetSupportedTargetsForTest(target);
        std::vector<float> out(view.total(), -1.0f);
        int64_t used = 0;
        ASSERT_TRUE(WarpByHomography(Span(view), width, height, H, out, &used));
        if (width == 37 && rho == 1.0) {
          std::cout << "Highway target " << hwy::TargetName(target) << " (ran "
                    << hwy::TargetName(used) << ")\n";
        }
        EXPECT_EQ(used, target);
        EXPECT_EQ(out, reference) << hwy::TargetName(target) << ", width " << width << ", rho "
                                  << rho;
        ++ran;
      }
      hwy::SetSupportedTargetsForTest(0);
      EXPECT_GE(ran, 1);
    }
  }
}

TEST(WarpByHomography, BehindTheViewSamplesItsFirstPixel) {
  const cv::Mat view = Image(16, 8, 1);
  Eigen::Matrix3d H = Eigen::Matrix3d::Identity();
  H(2, 2) = -1;  // z < 0 everywhere.
  std::vector<float> out(view.total());
  ASSERT_TRUE(WarpByHomography(Span(view), 16, 8, H, out));
  for (const float v : out) EXPECT_EQ(v, view.at<float>(0, 0));
}

TEST(WarpByHomography, RefusesSizesThatDoNotFit) {
  const cv::Mat view = Image(20, 12, 1);
  std::vector<float> out(view.total()), short_out(view.total() - 1);
  const Eigen::Matrix3d H = Eigen::Matrix3d::Identity();
  EXPECT_FALSE(WarpByHomography(Span(view), 20, 12, H, short_out));
  EXPECT_FALSE(WarpByHomographyScalar(Span(view), 21, 12, H, out));
  EXPECT_FALSE(WarpByHomography(Span(view), 0, 12, H, out));
  EXPECT_TRUE(WarpByHomography(Span(view), 20, 12, H, out));
  // The identity reproduces the view.
  for (size_t i = 0; i < out.size(); ++i) EXPECT_EQ(out[i], view.ptr<float>()[i]);
}

}  // namespace
}  // namespace mm
