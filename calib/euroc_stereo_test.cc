// EuRoC V1_01 stereo (../shared/data/euroc_v101_stereo_static): with the published
// radial-tangential distortion applied through the Bouguet model, SIFT matches of a cam0/cam1
// pair fit the ground-truth essential matrix (from the two T_BS) with a small epipolar error;
// ignoring the distortion they do not.

#include <gtest/gtest.h>

#include <Eigen/LU>
#include <algorithm>
#include <iostream>
#include <opencv2/core/persistence.hpp>
#include <opencv2/features2d.hpp>
#include <opencv2/imgcodecs.hpp>

#include "calib/camera_model.h"
#include "tests/support/shared_data.h"

namespace mm {
namespace {

struct EurocCam {
  BouguetCamera camera;
  Eigen::Matrix4d T_BS;  // Sensor to body.
};

EurocCam ReadSensor(const std::filesystem::path& yaml) {
  cv::FileStorage fs(yaml.string(), cv::FileStorage::READ);
  EXPECT_TRUE(fs.isOpened()) << yaml;
  std::vector<double> t, k, d;
  std::vector<int> res;
  fs["T_BS"]["data"] >> t;
  fs["intrinsics"] >> k;
  fs["distortion_coefficients"] >> d;
  fs["resolution"] >> res;
  EXPECT_EQ(t.size(), 16u);
  EXPECT_EQ(k.size(), 4u);
  EXPECT_EQ(d.size(), 4u);
  EurocCam c;
  for (int i = 0; i < 16; ++i) c.T_BS(i / 4, i % 4) = t[static_cast<size_t>(i)];
  c.camera.fc = {k[0], k[1]};
  c.camera.cc = {k[2], k[3]};
  c.camera.kc = {d[0], d[1], d[2], d[3], 0.0};  // radial-tangential [k1 k2 p1 p2] = Bouguet kc.
  c.camera.width = res[0];
  c.camera.height = res[1];
  return c;
}

Eigen::Matrix3d Skew(const Eigen::Vector3d& v) {
  Eigen::Matrix3d s;
  s << 0, -v.z(), v.y(), v.z(), 0, -v.x(), -v.y(), v.x(), 0;
  return s;
}

// Median Sampson distance (in pixels, normalized error times the mean focal length).
double MedianSampsonPx(const std::vector<Eigen::Vector2d>& x0,
                       const std::vector<Eigen::Vector2d>& x1, const Eigen::Matrix3d& E,
                       double focal) {
  std::vector<double> errors;
  for (size_t i = 0; i < x0.size(); ++i) {
    const Eigen::Vector3d a(x0[i].x(), x0[i].y(), 1.0), b(x1[i].x(), x1[i].y(), 1.0);
    const Eigen::Vector3d ea = E * a, etb = E.transpose() * b;
    const double e = b.dot(ea);
    const double denom = ea.head<2>().squaredNorm() + etb.head<2>().squaredNorm();
    errors.push_back(std::abs(e) / std::sqrt(denom) * focal);
  }
  std::nth_element(errors.begin(), errors.begin() + static_cast<long>(errors.size() / 2),
                   errors.end());
  return errors[errors.size() / 2];
}

TEST(EurocStereo, DistortionMakesSiftMatchesFitGroundTruthEssential) {
  const auto dir = test::RequireSharedData("euroc_v101_stereo_static") / "mav0";
  const EurocCam cam0 = ReadSensor(dir / "cam0" / "sensor.yaml");
  const EurocCam cam1 = ReadSensor(dir / "cam1" / "sensor.yaml");
  // X_c1 = R X_c0 + t, from T_c1_c0 = inv(T_B_c1) T_B_c0.
  const Eigen::Matrix4d T10 = cam1.T_BS.inverse() * cam0.T_BS;
  const Eigen::Matrix3d R = T10.topLeftCorner<3, 3>();
  const Eigen::Vector3d t = T10.topRightCorner<3, 1>();
  EXPECT_NEAR(t.norm(), 0.1101, 1e-3);  // PROVENANCE.md: baseline 0.1101 m.
  const Eigen::Matrix3d E = Skew(t) * R;

  const std::string frame = "1403715273262142976.png";
  const cv::Mat img0 = cv::imread((dir / "cam0" / "data" / frame).string(), cv::IMREAD_GRAYSCALE);
  const cv::Mat img1 = cv::imread((dir / "cam1" / "data" / frame).string(), cv::IMREAD_GRAYSCALE);
  ASSERT_FALSE(img0.empty());
  ASSERT_FALSE(img1.empty());
  auto sift = cv::SIFT::create(2000);
  std::vector<cv::KeyPoint> k0, k1;
  cv::Mat d0, d1;
  sift->detectAndCompute(img0, cv::noArray(), k0, d0);
  sift->detectAndCompute(img1, cv::noArray(), k1, d1);
  cv::BFMatcher matcher(cv::NORM_L2);
  std::vector<std::vector<cv::DMatch>> knn;
  matcher.knnMatch(d0, d1, knn, 2);
  std::vector<Eigen::Vector2d> und0, und1, raw0, raw1;
  for (const auto& m : knn) {
    if (m.size() < 2 || m[0].distance > 0.8f * m[1].distance) continue;  // Lowe's ratio test.
    const cv::Point2f p0 = k0[static_cast<size_t>(m[0].queryIdx)].pt;
    const cv::Point2f p1 = k1[static_cast<size_t>(m[0].trainIdx)].pt;
    und0.push_back(cam0.camera.Unproject({p0.x, p0.y}));
    und1.push_back(cam1.camera.Unproject({p1.x, p1.y}));
    raw0.push_back(cam0.camera.Undistorted().Unproject({p0.x, p0.y}));
    raw1.push_back(cam1.camera.Undistorted().Unproject({p1.x, p1.y}));
  }
  ASSERT_GT(und0.size(), 100u);
  const double focal = (cam0.camera.fc.mean() + cam1.camera.fc.mean()) / 2;
  const double with = MedianSampsonPx(und0, und1, E, focal);
  const double without = MedianSampsonPx(raw0, raw1, E, focal);
  std::cout << und0.size() << " matches; median epipolar (Sampson) error " << with
            << " px with the distortion, " << without << " px without\n";
  // Measured: 458 matches, 0.110 px with the distortion, 0.569 px without.
  EXPECT_LE(with, 0.2);          // Issue 3: <= 0.2 px.
  EXPECT_GT(without, 2 * with);  // Ignoring the lens is clearly worse (~0.5 px expected).
}

}  // namespace
}  // namespace mm
