// Calibration on synthetic board views rendered through a known camera (no data files needed;
// the real images are in calibrate_data_test.cc).

#include "calib/calibrate.h"

#include <gtest/gtest.h>

#include <iostream>
#include <opencv2/calib3d.hpp>
#include <random>

#include "calib/undistort.h"

namespace mm {
namespace {

BouguetCamera KnownCamera(double alpha_c) {
  BouguetCamera c;
  c.fc = {652.0, 655.5};
  c.cc = {311.2, 236.8};
  c.alpha_c = alpha_c;
  c.kc = {-0.24, 0.11, 0.0008, -0.0005, 0.0};
  c.width = 640;
  c.height = 480;
  return c;
}

// Board views rendered through `camera` from random poses facing the camera, with Gaussian
// corner noise (seeded).
std::vector<BoardView> SyntheticViews(const BouguetCamera& camera, const CalibrateOptions& o,
                                      int count, double noise_px, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> tilt(-0.6, 0.6), roll(-0.4, 0.4), dist(450, 750),
      shift(-80, 80);
  std::normal_distribution<double> noise(0.0, noise_px);
  const double bw = (o.board.width - 1) * o.square, bh = (o.board.height - 1) * o.square;
  std::vector<BoardView> views;
  while (static_cast<int>(views.size()) < count) {
    cv::Matx33d R;
    cv::Rodrigues(cv::Vec3d(tilt(rng), tilt(rng), roll(rng)), R);
    const cv::Vec3d t0(shift(rng), shift(rng), dist(rng));
    // Centre the board on the optical axis (plus a shift): t = t0 - R * centre.
    const cv::Vec3d t = t0 - R * cv::Vec3d(bw / 2, bh / 2, 0);
    BoardView v;
    v.name = "synthetic" + std::to_string(views.size());
    bool inside = true;
    for (int r = 0; r < o.board.height && inside; ++r) {
      for (int c = 0; c < o.board.width; ++c) {
        const cv::Vec3d p = R * cv::Vec3d(c * o.square, r * o.square, 0) + t;
        const Eigen::Vector2d px = camera.Project(Eigen::Vector3d(p[0], p[1], p[2]));
        if (px.x() < 5 || px.y() < 5 || px.x() > camera.width - 6 || px.y() > camera.height - 6) {
          inside = false;
          break;
        }
        v.corners.emplace_back(static_cast<float>(px.x() + noise(rng)),
                               static_cast<float>(px.y() + noise(rng)));
      }
    }
    if (inside) views.push_back(std::move(v));
  }
  return views;
}

TEST(Calibrate, SyntheticSkewedCameraIsRecovered) {
  const BouguetCamera truth = KnownCamera(0.004);  // ~0.23 deg skew.
  CalibrateOptions o;
  o.board = {9, 6};
  o.square = 30.0;
  o.est_alpha = true;
  const auto views = SyntheticViews(truth, o, 20, 0.15, 42);
  const CalibrateResult r = CalibrateFromViews(views, {640, 480}, o);
  ASSERT_TRUE(r.ok) << r.failure_reason;
  std::cout << r.Summary() << "\n";
  ASSERT_TRUE(r.camera.error.has_value());
  const auto& e = *r.camera.error;
  // Each estimate within its own 3-sigma bound (plus a small floor), and the noise level seen.
  EXPECT_NEAR(r.camera.alpha_c, truth.alpha_c, std::max(e.alpha_c, 1e-4));
  EXPECT_GT(e.alpha_c, 0.0);
  EXPECT_NEAR(r.camera.fc.x(), truth.fc.x(), std::max(e.fc.x(), 0.1));
  EXPECT_NEAR(r.camera.fc.y(), truth.fc.y(), std::max(e.fc.y(), 0.1));
  EXPECT_NEAR(r.camera.cc.x(), truth.cc.x(), std::max(e.cc.x(), 0.1));
  EXPECT_NEAR(r.camera.cc.y(), truth.cc.y(), std::max(e.cc.y(), 0.1));
  EXPECT_NEAR(r.camera.kc[0], truth.kc[0], std::max(e.kc[0], 1e-3));
  EXPECT_NEAR(r.camera.kc[1], truth.kc[1], std::max(e.kc[1], 1e-3));
  EXPECT_NEAR(r.rms_px, 0.15 * std::sqrt(2.0), 0.03);
  // The initial guess (OpenCV) has no skew; the refinement found it.
  EXPECT_EQ(r.initial.alpha_c, 0.0);
  // The undistortion uses the estimated skew.
  const Undistorter u(r.camera);
  EXPECT_EQ(u.output_camera().alpha_c, r.camera.alpha_c);
}

TEST(Calibrate, SyntheticFlagsHoldParametersFixed) {
  const BouguetCamera truth = KnownCamera(0.0);
  CalibrateOptions o;
  o.est_dist = {1, 1, 0, 0, 0};
  o.center_optim = false;
  o.est_aspect_ratio = false;
  const auto views = SyntheticViews(truth, o, 12, 0.1, 7);
  const CalibrateResult r = CalibrateFromViews(views, {640, 480}, o);
  ASSERT_TRUE(r.ok) << r.failure_reason;
  EXPECT_EQ(r.camera.alpha_c, 0.0);
  EXPECT_EQ(r.camera.kc[2], 0.0);
  EXPECT_EQ(r.camera.kc[3], 0.0);
  EXPECT_EQ(r.camera.kc[4], 0.0);
  EXPECT_EQ(r.camera.cc.x(), 319.5);
  EXPECT_EQ(r.camera.cc.y(), 239.5);
  EXPECT_EQ(r.camera.fc.x(), r.camera.fc.y());
  EXPECT_EQ(r.camera.error->cc.x(), 0.0);
  EXPECT_EQ(r.flags.center_optim, 0);
  // The model is wrong (cc, tangential and aspect held), so the fit is worse than the noise.
  EXPECT_GT(r.rms_px, 0.1);
}

TEST(Calibrate, TooFewViewsIsAReportedFailure) {
  CalibrateOptions o;
  std::vector<BoardView> views(2);
  const CalibrateResult r = CalibrateFromViews(views, {640, 480}, o);
  EXPECT_FALSE(r.ok);
  EXPECT_NE(r.failure_reason.find("at least 3"), std::string::npos);
  o.square = -1;
  EXPECT_EQ(o.Check().rfind("square", 0), 0u);
}

}  // namespace
}  // namespace mm
