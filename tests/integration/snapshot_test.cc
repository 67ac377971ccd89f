// `monomesh snapshot`: calibration views from a camera URI, here the replay camera over the
// Bouguet toolbox's chessboard images with frames of an office (no board) between them. With
// --board only the views showing the board are kept, and `monomesh calibrate` takes the folder.

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <opencv2/imgcodecs.hpp>

#include "calib/calibrate.h"
#include "tests/support/run_command.h"
#include "tests/support/shared_data.h"
#include "tests/support/temp_dir.h"

namespace mm::test {
namespace {

namespace fs = std::filesystem;

const fs::path kOffice = fs::path(MM_SOURCE_DIR) / "data/tum_office";

// A TUM folder interleaving `boards` chessboard images with office frames.
fs::path MakeCameraFolder(const fs::path& chessboards, int boards) {
  const fs::path dir = FreshTempDir("snapshot");
  fs::create_directories(dir / "rgb");
  std::ofstream list(dir / "rgb.txt");
  std::vector<fs::path> office;
  for (const auto& item : fs::directory_iterator(kOffice / "rgb")) office.push_back(item.path());
  std::sort(office.begin(), office.end());
  double t = 1.0;
  for (int i = 1; i <= boards; ++i) {
    const fs::path other = office[static_cast<size_t>(i) % office.size()];
    fs::create_symlink(other, dir / "rgb" / ("office" + std::to_string(i) + ".png"));
    list << t << " rgb/office" << i << ".png\n";
    t += 0.1;
    fs::create_symlink(chessboards / ("Image" + std::to_string(i) + ".tif"),
                       dir / "rgb" / ("board" + std::to_string(i) + ".tif"));
    list << t << " rgb/board" << i << ".tif\n";
    t += 0.1;
  }
  return dir;
}

TEST(Snapshot, KeepsOnlyViewsShowingTheBoardAndCalibrateTakesThem) {
  ASSERT_FALSE(Monomesh().empty()) << "MONOMESH is not set (run through ctest)";
  const fs::path chessboards = RequireSharedData("calib_bouguet_example_chessboard") / "images";
  const fs::path camera = MakeCameraFolder(chessboards, 8);
  const fs::path out = camera / "views";
  int status = -1;
  const std::string log =
      RunCommand(Monomesh() + " snapshot --camera 'replay:" + camera.string() +
                     "?rate=max' --out " + out.string() + " --count 6 --interval 0 --board 12x13",
                 &status);
  ASSERT_EQ(status, 0) << log;
  int views = 0;
  for (const auto& item : fs::directory_iterator(out)) {
    const cv::Mat image = cv::imread(item.path().string(), cv::IMREAD_GRAYSCALE);
    ASSERT_FALSE(image.empty()) << item.path();
    EXPECT_FALSE(DetectBoard(image, {12, 13}).empty()) << item.path() << " shows no board";
    ++views;
  }
  EXPECT_EQ(views, 6) << log;

  const std::string calibrated =
      RunCommand(Monomesh() + " calibrate --images " + out.string() +
                     " --board 12x13 --square 30 --out " + (camera / "calib").string(),
                 &status);
  EXPECT_EQ(status, 0) << calibrated;
  EXPECT_TRUE(fs::exists(camera / "calib" / "Calib_Results.m")) << calibrated;

  // Without --board every view is kept; a bad board or camera is named.
  RunCommand(Monomesh() + " snapshot --camera 'replay:" + camera.string() + "?rate=max' --out " +
                 (camera / "any").string() + " --count 3 --interval 0",
             &status);
  EXPECT_EQ(status, 0);
  EXPECT_EQ(std::distance(fs::directory_iterator(camera / "any"), fs::directory_iterator()), 3);
  const std::string bad_board =
      RunCommand(Monomesh() + " snapshot --camera replay:" + camera.string() + " --out " +
                     out.string() + " --board 12",
                 &status);
  EXPECT_EQ(status, 2);
  EXPECT_NE(bad_board.find("--board must be COLSxROWS"), std::string::npos) << bad_board;
  const std::string no_camera = RunCommand(
      Monomesh() + " snapshot --camera replay:/nonexistent --out " + out.string(), &status);
  EXPECT_EQ(status, 1);
  EXPECT_NE(no_camera.find("/nonexistent"), std::string::npos) << no_camera;
  // More views than the camera has: it says how many it got.
  const std::string ended = RunCommand(
      Monomesh() + " snapshot --camera 'replay:" + camera.string() + "?rate=max' --out " +
          (camera / "more").string() + " --count 20 --interval 0 --board 12x13",
      &status);
  EXPECT_EQ(status, 1);
  EXPECT_NE(ended.find("the camera ended after 8 views"), std::string::npos) << ended;
  fs::remove_all(camera);
}

}  // namespace
}  // namespace mm::test
