// Calib_Results.m reader/writer on text written here (errors, round trips, both formats); the
// real files are checked in calib_results_m_data_test.cc.

#include "calib/calib_results_m.h"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "calib/calib_io.h"
#include "calib/calib_results_m_test_support.h"

namespace mm {
namespace {

using test::ExpectSameResults;

constexpr const char* kMinimal =
    "%-- comment\r\nfc = [ 500.5 ; 501.25 ];\r\ncc = [ 319.5 ; 239.5 ];\r\n"
    "kc = [ -0.1 ; 0.01 ; 0.001 ; -0.002 ];\r\nnx = 640;\r\nny = 480;\r\n";

TEST(CalibResultsM, FourElementKcAndNoErrors) {
  const CalibResults r = ParseCalibResultsM(kMinimal, "min.m");
  EXPECT_EQ(r.camera.kc[3], -0.002);
  EXPECT_EQ(r.camera.kc[4], 0.0);
  EXPECT_EQ(r.camera.alpha_c, 0.0);
  EXPECT_FALSE(r.camera.error.has_value());
  EXPECT_FALSE(r.flags.has_value());
  ExpectSameResults(r, ParseCalibResultsM(FormatCalibResultsM(r), "again"), "minimal");
}

TEST(CalibResultsM, RoundTripsAWrittenCalibrationExactly) {
  CalibResults r;
  r.camera.fc = {657.4629028719112, 657.9467290401972};
  r.camera.cc = {303.13664895323342, 242.56934955799636};
  r.camera.alpha_c = 0.000411144009279;
  r.camera.kc = {-0.254025426082504, 0.121433038319927, -0.000208645997378, 1.941918022e-05, -0.0};
  r.camera.width = 640;
  r.camera.height = 480;
  BouguetCamera::Uncertainty e;
  e.fc = {0.318188661371089, 0.340463139314217};
  e.alpha_c = 1e-4;
  r.camera.error = e;
  r.n_ima = 3;
  r.flags = CalibEstimationFlags{};
  r.flags->est_alpha = 1;
  r.images.resize(3);
  r.images[0] = {Eigen::Vector3d(1.6549, 1.65199, -0.6694056),
                 Eigen::Vector3d(-177.7, -83.8, 853.1), Eigen::Vector3d(1e-3, 2e-3, 3e-3),
                 Eigen::Vector3d(0.8, 0.7, 0.4), true};
  r.images[2] = {Eigen::Vector3d(0.1, 0.2, 0.3), Eigen::Vector3d(1, 2, 3), std::nullopt,
                 std::nullopt, true};
  const std::string text = FormatCalibResultsM(r);
  EXPECT_NE(text.find("omc_2 = [ NaN ; NaN ; NaN ];"), std::string::npos) << text;
  EXPECT_NE(text.find("%-- Focal length:\nfc = [ "), std::string::npos);
  ExpectSameResults(r, ParseCalibResultsM(text, "written.m"), "written");
}

void ExpectError(const std::string& text, const std::string& needle) {
  try {
    (void)ParseCalibResultsM(text, "bad.m");
    ADD_FAILURE() << "no error for: " << text;
  } catch (const CalibrationError& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find("bad.m"), std::string::npos) << msg;
    EXPECT_NE(msg.find(needle), std::string::npos) << msg;
  }
}

TEST(CalibResultsM, ErrorsNameFileLineAndField) {
  const std::string base = "nx = 640;\nny = 480;\n";
  ExpectError("cc = [1;2];\nkc = [0;0;0;0;0];\n" + base, "field 'fc': missing");
  ExpectError("fc = [1;2];\nkc = [0;0;0;0;0];\n" + base, "field 'cc': missing");
  ExpectError("fc = [1;2];\ncc = [1;2];\n" + base, "field 'kc': missing");
  ExpectError("fc = [1;2;3];\ncc = [1;2];\nkc = [0;0;0;0;0];\n" + base,
              "bad.m:1: field 'fc': expected 2 values, got 3");
  ExpectError("%\nfc = [1;2];\ncc = [1;2];\nkc = [0;0;0];\n" + base, "bad.m:4: field 'kc'");
  ExpectError("fc = [NaN;2];\ncc = [1;2];\nkc = [0;0;0;0;0];\n" + base, "bad.m:1: field 'fc'");
  ExpectError("\nfc = [0;2];\ncc = [1;2];\nkc = [0;0;0;0;0];\n" + base, "bad.m:2: field 'fc'");
  ExpectError("fc = [1;2];\ncc = [1;2];\nkc = [0;0;0;0;0];\n", "field 'nx': missing");
  ExpectError("fc = [1;2];\ncc = [1;2];\nkc = [0;0;0;0;0];\nnx = 640.5;\nny = 480;\n",
              "bad.m:4: field 'nx'");
  // Above kMaxImageSide (OpenCV's undistortion maps of it threw from the daemon).
  ExpectError("fc = [1;2];\ncc = [1;2];\nkc = [0;0;0;0;0];\nnx = 1000000;\nny = 480;\n",
              "bad.m:4: field 'nx': expected an integer in [1, 16384]");
  ExpectError("fc = [1;x2];\ncc = [1;2];\nkc = [0;0;0;0;0];\n" + base,
              "bad.m:1: field 'fc': 'x2' is not a number");
  ExpectError("fc = [1;2\ncc = [1;2];\n", "field 'fc'");
  ExpectError(
      "fc = [1;2];\ncc = [1;2];\nkc = [0;0;0;0;0];\nnx = 640;\nny = 480;\n"
      "fc_error = [1;2];\n",
      "field 'cc_error': missing");
}

TEST(CalibResultsM, LoadCalibrationTakesBothFormats) {
  const auto dir = std::filesystem::temp_directory_path() / "mm_calib_results_m_test";
  std::filesystem::create_directories(dir);
  {
    std::ofstream(dir / "cam.m") << kMinimal;
    std::ofstream(dir / "cam_m_content.txt") << kMinimal;
    BouguetCamera c = ParseCalibResultsM(kMinimal, "x").camera;
    std::ofstream(dir / "cam.toml") << FormatCalibrationToml(c);
  }
  const BouguetCamera a = LoadCalibration(dir / "cam.m");
  const BouguetCamera b = LoadCalibration(dir / "cam_m_content.txt");
  const BouguetCamera t = LoadCalibration(dir / "cam.toml");
  EXPECT_EQ(a.fc, b.fc);
  EXPECT_EQ(a.fc, t.fc);
  EXPECT_EQ(a.kc, t.kc);
  EXPECT_EQ(t.width, 640);
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace mm
