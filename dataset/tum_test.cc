#include "dataset/tum.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

namespace mm {
namespace {

std::filesystem::path WriteTemp(const std::string& name, const std::string& text) {
  const auto dir = std::filesystem::temp_directory_path() / "mm_dataset_test";
  std::filesystem::create_directories(dir);
  const auto path = dir / name;
  std::ofstream(path) << text;
  return path;
}

TEST(TumList, ResolvesRelativePathsAndSkipsComments) {
  const auto file = WriteTemp("rgb.txt", "# header\n\n1.5 rgb/a.png\n2.5 /abs/b.png\n");
  const auto frames = ReadTumList(file);
  ASSERT_EQ(frames.size(), 2u);
  EXPECT_DOUBLE_EQ(frames[0].timestamp_s, 1.5);
  EXPECT_EQ(frames[0].path, file.parent_path() / "rgb/a.png");
  EXPECT_EQ(frames[1].path, std::filesystem::path("/abs/b.png"));
}

TEST(TumList, MalformedLineNamesFileAndLine) {
  const auto file = WriteTemp("bad.txt", "1.0 a.png\nnot-a-number\n");
  try {
    ReadTumList(file);
    FAIL() << "expected DatasetError";
  } catch (const DatasetError& e) {
    EXPECT_NE(std::string(e.what()).find("bad.txt:2"), std::string::npos) << e.what();
  }
}

TEST(Trajectory, InterpolatesPositionAndRotation) {
  TimedPose a, b;
  a.timestamp_s = 0.0;
  b.timestamp_s = 1.0;
  b.world_from_cam.translation() = Eigen::Vector3d(2, 0, 0);
  b.world_from_cam.linear() = Eigen::AngleAxisd(0.2, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  const Trajectory traj({b, a});
  const auto mid = traj.WorldFromCamAt(0.25);
  ASSERT_TRUE(mid.has_value());
  EXPECT_NEAR(mid->translation().x(), 0.5, 1e-12);
  EXPECT_NEAR(Eigen::AngleAxisd(mid->linear()).angle(), 0.05, 1e-12);
  EXPECT_TRUE(traj.WorldFromCamAt(1.05).has_value());
  EXPECT_FALSE(traj.WorldFromCamAt(1.5).has_value());
}

TEST(Metrics, RotationAndDirectionErrors) {
  const Eigen::Matrix3d r = Eigen::AngleAxisd(0.1, Eigen::Vector3d::UnitY()).toRotationMatrix();
  EXPECT_NEAR(RotationErrorDeg(r, Eigen::Matrix3d::Identity()), 0.1 * 180 / M_PI, 1e-9);
  EXPECT_NEAR(DirectionErrorDeg(Eigen::Vector3d(1, 0, 0), Eigen::Vector3d(0, 2, 0)), 90.0, 1e-9);
}

TEST(TumList, NearestFrameWithinTheLimit) {
  const std::vector<TumFrame> frames =
      ParseTumList("1.00 a.png\n1.10 b.png\n1.30 c.png\n", "/d", "l");
  EXPECT_EQ(NearestFrame(frames, 1.12, 0.05), 1);
  EXPECT_EQ(NearestFrame(frames, 1.24, 0.15), 2);
  EXPECT_EQ(NearestFrame(frames, 1.20, 0.05), -1);
  EXPECT_EQ(NearestFrame({}, 1.0, 1.0), -1);
}

}  // namespace
}  // namespace mm
