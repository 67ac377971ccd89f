// The dense depth's clean-up (recon/depth_filters.h) on small maps with known surfaces.

#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <opencv2/core.hpp>

#include "recon/depth_filters.h"

namespace mm {
namespace {

constexpr double kStep = 0.002;  // Plane spacing in inverse depth.
constexpr float kWall = 0.25f, kBox = 0.5f;

// A box (grey 200, inverse depth 0.5) in front of a wall (grey 60, 0.25); the box's outline in
// the image is x, y in [20, 40), its depth reaches `fattening` pixels past it on every side.
struct BoxScene {
  cv::Mat gray = cv::Mat(60, 60, CV_8UC1, cv::Scalar(60));
  cv::Mat rho = cv::Mat(60, 60, CV_32FC1, cv::Scalar(kWall));
  cv::Mat confidence = cv::Mat(60, 60, CV_32FC1, cv::Scalar(0.5));
  explicit BoxScene(int fattening, bool outline_visible = true) {
    if (outline_visible) gray(cv::Rect(20, 20, 20, 20)).setTo(200);
    rho(cv::Rect(20 - fattening, 20 - fattening, 20 + 2 * fattening, 20 + 2 * fattening))
        .setTo(kBox);
  }
};

TEST(DepthFilters, DepthEdgeNeedsMoreThanQuantization) {
  EXPECT_TRUE(IsDepthEdge(kBox, kWall, kStep));
  EXPECT_FALSE(IsDepthEdge(0.5f, 0.49f, kStep));   // 2 % of depth: one surface.
  EXPECT_FALSE(IsDepthEdge(0.1f, 0.094f, 0.002));  // Three plane steps at a far surface.
}

TEST(DepthFilters, CutsTheFattenedBoxBackToItsOutline) {
  BoxScene scene(/*fattening=*/3);
  const int dropped =
      CutDepthEdgesToOutlines(scene.gray, 3, 8, kStep, &scene.rho, &scene.confidence);
  // The ring of 3 pixels outside the outline goes, the box and the wall stay.
  EXPECT_EQ(dropped, 26 * 26 - 20 * 20);
  for (int y = 0; y < 60; ++y) {
    for (int x = 0; x < 60; ++x) {
      const bool box = x >= 20 && x < 40 && y >= 20 && y < 40;
      const bool ring = !box && x >= 17 && x < 43 && y >= 17 && y < 43;
      const float rho = scene.rho.at<float>(y, x);
      EXPECT_EQ(rho, ring ? 0.0f : (box ? kBox : kWall)) << x << ", " << y;
      if (ring) {
        EXPECT_EQ(scene.confidence.at<float>(y, x), 0.0f);
      }
    }
  }
}

TEST(DepthFilters, KeepsAnEdgeOnItsOutlineOrWithoutOne) {
  BoxScene exact(/*fattening=*/0);
  EXPECT_EQ(CutDepthEdgesToOutlines(exact.gray, 3, 8, kStep, &exact.rho, &exact.confidence), 0);
  // No grey-level outline to snap to: the depth edge stays where the sweep put it.
  BoxScene unseen(/*fattening=*/2, /*outline_visible=*/false);
  EXPECT_EQ(CutDepthEdgesToOutlines(unseen.gray, 3, 8, kStep, &unseen.rho, &unseen.confidence), 0);
  // Off.
  BoxScene off(/*fattening=*/2);
  EXPECT_EQ(CutDepthEdgesToOutlines(off.gray, 3, 0, kStep, &off.rho, &off.confidence), 0);
}

TEST(DepthFilters, ASteepSlantIsNotAnEdge) {
  // A floor seen at a grazing angle: inverse depth falls by 0.01 per pixel, within the
  // depth-edge tolerance between neighbours but not over the band; a grey-level step on it.
  cv::Mat gray(40, 60, CV_8UC1, cv::Scalar(60)), rho(40, 60, CV_32FC1);
  gray.colRange(30, 60).setTo(200);
  for (int x = 0; x < rho.cols; ++x) rho.col(x).setTo(0.7f - 0.01f * static_cast<float>(x));
  cv::Mat confidence(rho.size(), CV_32FC1, cv::Scalar(0.5));
  EXPECT_EQ(CutDepthEdgesToOutlines(gray, 3, 8, kStep, &rho, &confidence), 0);
}

// rho = 0.2 + 0.001 x + 0.0005 y: a plane slanted against the image.
cv::Mat SlantedPlane() {
  cv::Mat rho(60, 80, CV_32FC1);
  for (int y = 0; y < rho.rows; ++y) {
    for (int x = 0; x < rho.cols; ++x) rho.at<float>(y, x) = 0.2f + 0.001f * x + 0.0005f * y;
  }
  return rho;
}

TEST(DepthFilters, FillsAHoleInAPlaneWithThePlane) {
  const cv::Mat truth = SlantedPlane();
  cv::Mat rho = truth.clone(), confidence(rho.size(), CV_32FC1, cv::Scalar(0.5));
  rho(cv::Rect(30, 20, 12, 9)).setTo(0);
  confidence(cv::Rect(30, 20, 12, 9)).setTo(0);
  EXPECT_EQ(FillPlanarHoles(200, 0.02f, kStep, &rho, &confidence), 12 * 9);
  EXPECT_LT(cv::norm(rho, truth, cv::NORM_INF), 1e-5);
  EXPECT_FLOAT_EQ(confidence.at<float>(24, 35), 0.02f);
  EXPECT_FLOAT_EQ(confidence.at<float>(5, 5), 0.5f);
}

TEST(DepthFilters, LeavesHolesBetweenSurfacesAtTheBorderOrTooLarge) {
  cv::Mat confidence(60, 80, CV_32FC1, cv::Scalar(0.5));
  // A hole on a depth edge: its border lies on two surfaces.
  cv::Mat between = SlantedPlane();
  between(cv::Rect(40, 0, 40, 60)) += 0.2f;
  between(cv::Rect(34, 20, 12, 9)).setTo(0);
  EXPECT_EQ(FillPlanarHoles(200, 0.02f, kStep, &between, &confidence), 0);
  // A hole that touches the image's border is open, not a hole in a surface.
  cv::Mat open = SlantedPlane();
  open(cv::Rect(0, 20, 12, 9)).setTo(0);
  EXPECT_EQ(FillPlanarHoles(200, 0.02f, kStep, &open, &confidence), 0);
  // Larger than the limit.
  cv::Mat large = SlantedPlane();
  large(cv::Rect(30, 20, 12, 9)).setTo(0);
  EXPECT_EQ(FillPlanarHoles(12 * 9 - 1, 0.02f, kStep, &large, &confidence), 0);
}

TEST(DepthFilters, MedianOfValidRemovesASpikeAndKeepsAnEdge) {
  cv::Mat rho(20, 20, CV_32FC1, cv::Scalar(kWall));
  rho(cv::Rect(10, 0, 10, 20)).setTo(kBox);
  rho.at<float>(5, 4) = 0.9f;
  const cv::Mat out = MedianOfValid(rho);
  EXPECT_EQ(out.at<float>(5, 4), kWall);
  EXPECT_EQ(out.at<float>(5, 9), kWall);
  EXPECT_EQ(out.at<float>(5, 10), kBox);
}

}  // namespace
}  // namespace mm
