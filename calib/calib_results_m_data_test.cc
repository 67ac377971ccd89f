// Calib_Results.m reader on the real files in ../shared/data/bouguet_calib_results_variants,
// checked against their MANIFEST.tsv (skips with 77 without the data).

#include <gtest/gtest.h>

#include "calib/calib_io.h"
#include "calib/calib_results_m.h"
#include "calib/calib_results_m_test_support.h"
#include "tests/support/shared_data.h"

namespace mm {
namespace {

using test::ExpectSameResults;
using test::ReadFile;
using test::SplitTabs;

TEST(CalibResultsMData, EveryManifestFileLoadsWithItsValues) {
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

TEST(CalibResultsMData, ReferenceFileValuesAndInactiveImages) {
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

}  // namespace
}  // namespace mm
