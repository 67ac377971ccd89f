#include "calib/undistort.h"

#include <gtest/gtest.h>

#include <opencv2/imgproc.hpp>

namespace mm {
namespace {

TEST(Undistorter, IdentityWithoutDistortion) {
  BouguetCamera c;
  c.fc = {500, 500};
  c.cc = {160, 120};
  c.width = 320;
  c.height = 240;
  const Undistorter u(c);
  cv::Mat frame(240, 320, CV_8UC1, cv::Scalar(7));
  EXPECT_EQ(u.Apply(frame).data, frame.data);
}

// A dot drawn where the distorted camera sees a 3-D point lands, after undistortion, where
// the undistorted camera sees it (checks the map direction, skew and distortion together).
TEST(Undistorter, MovesPointsToUndistortedProjection) {
  BouguetCamera c;
  c.fc = {400, 410};
  c.cc = {319.5, 239.5};
  c.alpha_c = 0.01;
  c.kc = {-0.3, 0.1, 0.001, -0.001, 0};
  c.width = 640;
  c.height = 480;
  const Undistorter u(c);
  const Eigen::Vector3d point(0.45, -0.3, 1.0);
  const Eigen::Vector2d distorted = c.Project(point);
  const Eigen::Vector2d expected = c.Undistorted().Project(point);
  cv::Mat frame(480, 640, CV_8UC1, cv::Scalar(0));
  cv::circle(frame,
             cv::Point(static_cast<int>(std::lround(distorted.x())),
                       static_cast<int>(std::lround(distorted.y()))),
             3, cv::Scalar(255), cv::FILLED);
  const cv::Mat out = u.Apply(frame);
  const cv::Moments m = cv::moments(out, false);
  ASSERT_GT(m.m00, 0);
  const Eigen::Vector2d centroid(m.m10 / m.m00, m.m01 / m.m00);
  EXPECT_LT((centroid - expected).norm(), 1.0)
      << centroid.transpose() << " vs " << expected.transpose();
}

// ApplyNearest copies values without blending: each output pixel holds the value of the input
// pixel nearest to where the model maps it (an image of coordinates tells which pixel came).
TEST(Undistorter, NearestTakesTheNearestInputPixel) {
  BouguetCamera c;
  c.fc = {265, 262};
  c.cc = {161.3, 118.2};
  c.alpha_c = 0.002;
  c.kc = {-0.28, 0.11, 0.0012, -0.0009, -0.02};
  c.width = 320;
  c.height = 240;
  const Undistorter u(c);
  cv::Mat coords(240, 320, CV_32FC2);
  for (int y = 0; y < 240; ++y) {
    for (int x = 0; x < 320; ++x) coords.at<cv::Vec2f>(y, x) = cv::Vec2f(x, y);
  }
  const cv::Mat out = u.ApplyNearest(coords);
  const BouguetCamera undistorted = c.Undistorted();
  int checked = 0;
  double worst = 0;
  for (int v = 0; v < 240; v += 7) {
    for (int uu = 0; uu < 320; uu += 7) {
      const Eigen::Vector2d ray = undistorted.Unproject(Eigen::Vector2d(uu, v));
      const Eigen::Vector2d src = c.Project(Eigen::Vector3d(ray.x(), ray.y(), 1.0));
      if (src.x() < 1 || src.y() < 1 || src.x() > 318 || src.y() > 238) continue;
      const cv::Vec2f got = out.at<cv::Vec2f>(v, uu);
      // Integral: copied, not blended; and the nearest pixel (the tables hold 1/32 pixel).
      EXPECT_EQ(got[0], std::round(got[0]));
      EXPECT_EQ(got[1], std::round(got[1]));
      worst = std::max({worst, std::abs(got[0] - src.x()), std::abs(got[1] - src.y())});
      ++checked;
    }
  }
  EXPECT_GT(checked, 1000);
  EXPECT_LE(worst, 0.5 + 1.0 / 32 + 1e-6);
}

// Feature points go where the frame's pixels go: the undistorted point of a distorted pixel
// projects back onto it, and matches the 3-D point's undistorted projection.
TEST(Undistorter, UndistortPointsMatchesModel) {
  BouguetCamera c;
  c.fc = {400, 410};
  c.cc = {319.5, 239.5};
  c.alpha_c = 0.01;
  c.kc = {-0.3, 0.1, 0.001, -0.001, 0.01};
  c.width = 640;
  c.height = 480;
  const Undistorter u(c);
  std::vector<cv::Point2f> pts;
  std::vector<Eigen::Vector2d> expected;
  for (const Eigen::Vector3d& p :
       {Eigen::Vector3d(0.45, -0.3, 1.0), Eigen::Vector3d(-0.6, 0.4, 1.2),
        Eigen::Vector3d(0.0, 0.0, 2.0)}) {
    const Eigen::Vector2d d = c.Project(p);
    pts.emplace_back(static_cast<float>(d.x()), static_cast<float>(d.y()));
    expected.push_back(u.output_camera().Project(p));
  }
  const auto out = u.UndistortPoints(pts);
  ASSERT_EQ(out.size(), pts.size());
  for (size_t i = 0; i < out.size(); ++i) {
    // float storage of the input pixel limits this to ~1e-4 px.
    EXPECT_NEAR(out[i].x, expected[i].x(), 1e-3);
    EXPECT_NEAR(out[i].y, expected[i].y(), 1e-3);
  }
}

TEST(Undistorter, RejectsWrongFrameSize) {
  BouguetCamera c;
  c.fc = {500, 500};
  c.width = 320;
  c.height = 240;
  c.kc[0] = 0.1;
  const Undistorter u(c);
  EXPECT_THROW((void)u.Apply(cv::Mat(100, 100, CV_8UC1)), std::invalid_argument);
}

}  // namespace
}  // namespace mm
