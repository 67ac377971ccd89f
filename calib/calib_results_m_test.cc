// Calib_Results.m reader/writer. The real files in ../shared/data/bouguet_calib_results_variants
// are checked against their MANIFEST.tsv; the error and round-trip cases use text written here.

#include "calib/calib_results_m.h"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "calib/calib_io.h"
#include "tests/support/shared_data.h"

namespace mm {
namespace {

std::string ReadFile(const std::filesystem::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

std::vector<std::string> SplitTabs(const std::string& line) {
  std::vector<std::string> out;
  std::string cell;
  std::istringstream in(line);
  while (std::getline(in, cell, '\t')) out.push_back(cell);
  if (!line.empty() && line.back() == '\t') out.emplace_back();
  return out;
}

// Equal, with NaN equal to NaN (inactive images).
bool Same(double a, double b) { return (std::isnan(a) && std::isnan(b)) || a == b; }

void ExpectSameResults(const CalibResults& a, const CalibResults& b, const std::string& what) {
  EXPECT_EQ(a.camera.fc, b.camera.fc) << what;
  EXPECT_EQ(a.camera.cc, b.camera.cc) << what;
  EXPECT_EQ(a.camera.alpha_c, b.camera.alpha_c) << what;
  EXPECT_EQ(a.camera.kc, b.camera.kc) << what;
  EXPECT_EQ(a.camera.width, b.camera.width) << what;
  EXPECT_EQ(a.camera.height, b.camera.height) << what;
  ASSERT_EQ(a.camera.error.has_value(), b.camera.error.has_value()) << what;
  if (a.camera.error) {
    EXPECT_EQ(a.camera.error->fc, b.camera.error->fc) << what;
    EXPECT_EQ(a.camera.error->cc, b.camera.error->cc) << what;
    EXPECT_EQ(a.camera.error->kc, b.camera.error->kc) << what;
    EXPECT_EQ(a.camera.error->alpha_c, b.camera.error->alpha_c) << what;
  }
  EXPECT_EQ(a.n_ima, b.n_ima) << what;
  ASSERT_EQ(a.flags.has_value(), b.flags.has_value()) << what;
  if (a.flags) {
    EXPECT_EQ(a.flags->est_dist, b.flags->est_dist) << what;
    EXPECT_EQ(a.flags->est_alpha, b.flags->est_alpha) << what;
    EXPECT_EQ(a.flags->center_optim, b.flags->center_optim) << what;
    EXPECT_EQ(a.flags->est_aspect_ratio, b.flags->est_aspect_ratio) << what;
    EXPECT_EQ(a.flags->est_fc, b.flags->est_fc) << what;
  }
  ASSERT_EQ(a.images.size(), b.images.size()) << what;
  for (size_t k = 0; k < a.images.size(); ++k) {
    EXPECT_EQ(a.images[k].active, b.images[k].active) << what << " image " << k + 1;
    for (int j = 0; j < 3; ++j) {
      if (a.images[k].active) {
        EXPECT_TRUE(Same(a.images[k].omc[j], b.images[k].omc[j])) << what << " omc " << k + 1;
        EXPECT_TRUE(Same(a.images[k].tc[j], b.images[k].tc[j])) << what << " Tc " << k + 1;
      }
    }
    ASSERT_EQ(a.images[k].omc_error.has_value(), b.images[k].omc_error.has_value());
    if (a.images[k].omc_error) {
      for (int j = 0; j < 3; ++j) {
        EXPECT_TRUE(Same((*a.images[k].omc_error)[j], (*b.images[k].omc_error)[j])) << what;
      }
    }
  }
}

TEST(CalibResultsM, EveryManifestFileLoadsWithItsValues) {
  const auto dir = test::RequireSharedData("bouguet_calib_results_variants");
  std::ifstream manifest(dir / "MANIFEST.tsv");
  ASSERT_TRUE(manifest);
  std::string line;
  std::getline(manifest, line);
  const auto header = SplitTabs(line);
  auto col = [&](const char* name) {
    for (size_t i = 0; i < header.size(); ++i) {
      if (header[i] == name) return i;
    }
    ADD_FAILURE() << "MANIFEST.tsv has no column " << name;
    return size_t{0};
  };
  const size_t c_file = col("file"), c_nx = col("nx"), c_ny = col("ny"), c_n = col("n_ima");
  const size_t c_alpha_est = col("est_alpha"), c_dist = col("est_dist");
  const size_t c_center = col("center_optim"), c_alpha = col("alpha_c");
  const size_t c_endings = col("line_endings");
  int files = 0;
  while (std::getline(manifest, line)) {
    if (line.empty()) continue;
    const auto cells = SplitTabs(line);
    ASSERT_GT(cells.size(), c_alpha);
    const std::string name = cells[c_file];
    SCOPED_TRACE(name);
    const std::string text = ReadFile(dir / name);
    EXPECT_EQ(text.find("\r\n") != std::string::npos, cells[c_endings] == "CRLF");
    EXPECT_TRUE(LooksLikeCalibResultsM(text));
    const CalibResults r = ParseCalibResultsM(text, name);
    ++files;
    EXPECT_EQ(r.camera.width, std::stoi(cells[c_nx]));
    EXPECT_EQ(r.camera.height, std::stoi(cells[c_ny]));
    EXPECT_DOUBLE_EQ(r.camera.alpha_c, std::stod(cells[c_alpha]));
    EXPECT_TRUE(r.camera.Check().empty());
    ASSERT_TRUE(r.camera.error.has_value());
    EXPECT_GT(r.camera.error->fc.x(), 0.0);
    if (cells[c_n].empty()) {  // Intrinsics-only file.
      EXPECT_EQ(r.n_ima, 0);
      EXPECT_FALSE(r.flags.has_value());
      EXPECT_TRUE(r.images.empty());
    } else {
      EXPECT_EQ(r.n_ima, std::stoi(cells[c_n]));
      ASSERT_TRUE(r.flags.has_value());
      EXPECT_EQ(r.flags->est_alpha, std::stoi(cells[c_alpha_est]));
      EXPECT_EQ(r.flags->center_optim, std::stoi(cells[c_center]));
      std::string dist = "[";
      for (int i = 0; i < 5; ++i)
        dist += std::to_string(r.flags->est_dist[i]) + (i < 4 ? ";" : "]");
      EXPECT_EQ(dist, cells[c_dist]);
      ASSERT_EQ(r.images.size(), static_cast<size_t>(r.n_ima));
      int active = 0;
      for (const auto& p : r.images) active += p.active ? 1 : 0;
      EXPECT_GT(active, 0);
    }
    // The writer reads back to the same values.
    ExpectSameResults(r, ParseCalibResultsM(FormatCalibResultsM(r), name + " (rewritten)"), name);
    // And LoadCalibration takes the file as it is.
    EXPECT_EQ(LoadCalibration(dir / name).fc, r.camera.fc);
  }
  EXPECT_EQ(files, 17);
}

TEST(CalibResultsM, ReferenceFileValuesAndInactiveImages) {
  const auto dir = test::RequireSharedData("bouguet_calib_results_variants");
  const CalibResults ref =
      ParseCalibResultsM(ReadFile(dir / "01_bouguet_calib_example_reference.m"), "01");
  EXPECT_DOUBLE_EQ(ref.camera.fc.x(), 657.462902871911183);
  EXPECT_DOUBLE_EQ(ref.camera.cc.y(), 242.569349557996361);
  EXPECT_DOUBLE_EQ(ref.camera.kc[3], 0.000019419180220);
  EXPECT_DOUBLE_EQ(ref.camera.error->cc.x(), 0.646820768584764);
  EXPECT_DOUBLE_EQ(ref.images[0].tc.z(), 8.531470e+02);
  EXPECT_DOUBLE_EQ((*ref.images[0].tc_error).x(), 8.399644e-01);

  // 07: images 2, 3 and 6 inactive (NaN), as its MANIFEST notes say.
  const CalibResults nan =
      ParseCalibResultsM(ReadFile(dir / "07_nan_extrinsics_inactive_images.m"), "07");
  for (int k = 1; k <= nan.n_ima; ++k) {
    EXPECT_EQ(nan.images[static_cast<size_t>(k - 1)].active, !(k == 2 || k == 3 || k == 6)) << k;
  }
  // 03: skew estimated, kc(5) printed as negative zero.
  const CalibResults skew =
      ParseCalibResultsM(ReadFile(dir / "03_bouguet_calib_example_rerun_sergioroubles.m"), "03");
  EXPECT_DOUBLE_EQ(skew.camera.alpha_c, 0.000411144009279);
  EXPECT_EQ(skew.camera.kc[4], 0.0);
  EXPECT_EQ(skew.flags->est_alpha, 1);
  // 08: Windows 3-digit exponents in the extrinsics.
  const CalibResults win =
      ParseCalibResultsM(ReadFile(dir / "08_three_digit_exponent_windows.m"), "08");
  EXPECT_TRUE(win.images[0].active);
  EXPECT_TRUE(win.images[0].omc.allFinite());
}

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
