// Runs the whole pair pipeline on the bundled TUM keyframes (committed, so never skipped)
// and checks the relative pose against the motion-capture ground truth.
#include "recon/pipeline.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "calib/calib_io.h"
#include "dataset/tum.h"

namespace mm {
namespace {

const std::filesystem::path kData = std::filesystem::path(MM_SOURCE_DIR) / "data/tum_office";

// ExtractSift's resize paths (first_octave >= 0, resize_factor < 1) map keypoints back to the
// original pixels: Gaussian blobs at known sub-pixel centres are found within a pixel.
TEST(ExtractSift, ResizedPathsMapKeypointsBack) {
  cv::Mat image(480, 640, CV_32F, cv::Scalar(0));
  std::vector<cv::Point2f> centres;
  for (int gy = 0; gy < 4; ++gy) {
    for (int gx = 0; gx < 5; ++gx) {
      const cv::Point2f c(70.3f + 120.0f * static_cast<float>(gx),
                          60.7f + 115.0f * static_cast<float>(gy));
      centres.push_back(c);
      for (int y = -25; y <= 25; ++y) {
        for (int x = -25; x <= 25; ++x) {
          const int px = static_cast<int>(c.x) + x, py = static_cast<int>(c.y) + y;
          const float dx = static_cast<float>(px) - c.x, dy = static_cast<float>(py) - c.y;
          image.at<float>(py, px) += 200.0f * std::exp(-(dx * dx + dy * dy) / (2 * 5.0f * 5.0f));
        }
      }
    }
  }
  cv::Mat gray;
  image.convertTo(gray, CV_8U);
  for (const auto& [first_octave, resize] :
       {std::pair{-1, 1.0}, std::pair{-1, 0.75}, std::pair{0, 1.0}}) {
    SiftOptions o;
    o.first_octave = first_octave;
    o.resize_factor = resize;
    const Features f = ExtractSift(gray, o);
    int found = 0;
    for (const cv::Point2f& c : centres) {
      double best = 1e9;
      for (const cv::KeyPoint& k : f.keypoints) best = std::min(best, cv::norm(k.pt - c));
      // Measured 0.3-0.7 px from the blob centres; a wrong mapping is pixels off.
      found += best < 1.0 ? 1 : 0;
    }
    EXPECT_EQ(found, static_cast<int>(centres.size()))
        << "first_octave " << first_octave << " resize " << resize;
  }
}

TEST(ReconstructPair, TumKeyframePairMatchesGroundTruth) {
  const BouguetCamera camera = LoadCalibration(kData / "calib.toml");
  const auto frames = ReadTumList(kData / "rgb.txt");
  const Trajectory gt = Trajectory::Read(kData / "groundtruth.txt");
  for (const auto& [ia, ib] : {std::pair{0, 1}, std::pair{1, 2}, std::pair{2, 3}}) {
    const cv::Mat a = cv::imread(frames[static_cast<size_t>(ia)].path.string());
    const cv::Mat b = cv::imread(frames[static_cast<size_t>(ib)].path.string());
    const PairReconstruction r = ReconstructPair(a, b, camera, PairOptions{});
    ASSERT_TRUE(r.success) << r.failure_reason;
    const auto pose_a = gt.WorldFromCamAt(frames[static_cast<size_t>(ia)].timestamp_s);
    const auto pose_b = gt.WorldFromCamAt(frames[static_cast<size_t>(ib)].timestamp_s);
    ASSERT_TRUE(pose_a && pose_b);
    const Eigen::Isometry3d b_from_a = CamBFromCamA(*pose_a, *pose_b);
    // Thresholds from measurement (OpenCV five-point path): rotation ~0.3 deg, direction a
    // few degrees; the peers' figures are in docs/.
    EXPECT_LT(RotationErrorDeg(r.geometry.rotation, b_from_a.linear()), 1.0);
    EXPECT_LT(DirectionErrorDeg(r.geometry.translation, b_from_a.translation()), 10.0);
    EXPECT_GT(r.mesh.vertices.size(), 200u);
    EXPECT_GT(r.mesh.triangles.size(), 300u);
    EXPECT_EQ(r.mesh.colors.size(), r.mesh.vertices.size());
    // The observations in B were refined (Lucas-Kanade) and the points triangulated again.
    EXPECT_EQ(r.refinement.points, static_cast<int>(r.geometry.points_in_cam_a.size()));
    EXPECT_GT(r.refinement.refined, r.refinement.points / 2);
    EXPECT_EQ(r.point_pixels_b.size(), r.geometry.points_in_cam_a.size());
  }
}

// Lengths scale, rotations and pixels keep: the pair in metres.
TEST(ScalePairReconstruction, ScalesEveryLengthOnly) {
  PairReconstruction r;
  r.geometry.rotation = Eigen::AngleAxisd(0.1, Eigen::Vector3d::UnitY()).toRotationMatrix();
  r.geometry.translation = Eigen::Vector3d(0.6, 0.0, 0.8);
  r.geometry.points_in_cam_a = {Eigen::Vector3d(1, 2, 4)};
  r.point_pixels_a = {Eigen::Vector2d(10, 20)};
  r.mesh.vertices = {Eigen::Vector3f(1, 1, 2)};
  r.mesh_summary.voxel_size = 0.05;
  const Eigen::Matrix3d rotation = r.geometry.rotation;
  ScalePairReconstruction(0.25, &r);
  EXPECT_NEAR(r.geometry.translation.norm(), 0.25, 1e-12);
  EXPECT_EQ(r.geometry.points_in_cam_a[0], Eigen::Vector3d(0.25, 0.5, 1.0));
  EXPECT_EQ(r.mesh.vertices[0], Eigen::Vector3f(0.25f, 0.25f, 0.5f));
  EXPECT_NEAR(r.mesh_summary.voxel_size, 0.0125, 1e-15);
  EXPECT_EQ(r.geometry.rotation, rotation);
  EXPECT_EQ(r.point_pixels_a[0], Eigen::Vector2d(10, 20));
}

TEST(ReconstructPair, IdenticalImagesFailWithReason) {
  const BouguetCamera camera = LoadCalibration(kData / "calib.toml");
  const auto frames = ReadTumList(kData / "rgb.txt");
  const cv::Mat a = cv::imread(frames[0].path.string());
  const PairReconstruction r = ReconstructPair(a, a, camera, PairOptions{});
  EXPECT_FALSE(r.success);
  EXPECT_FALSE(r.failure_reason.empty());
}

TEST(ReconstructPair, MismatchedSizesFailWithReason) {
  BouguetCamera camera;
  camera.fc = {500, 500};
  const PairReconstruction r =
      ReconstructPair(cv::Mat(10, 10, CV_8UC1), cv::Mat(20, 10, CV_8UC1), camera, PairOptions{});
  EXPECT_FALSE(r.success);
  EXPECT_NE(r.failure_reason.find("sizes"), std::string::npos);
}

}  // namespace
}  // namespace mm
