#pragma once
// Helpers shared by the Calib_Results.m tests (test-only).

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "calib/calib_results_m.h"
#include "tests/support/read_file.h"

namespace mm::test {

inline std::vector<std::string> SplitTabs(const std::string& line) {
  std::vector<std::string> out;
  std::string cell;
  std::istringstream in(line);
  while (std::getline(in, cell, '\t')) out.push_back(cell);
  if (!line.empty() && line.back() == '\t') out.emplace_back();
  return out;
}

// Equal, with NaN equal to NaN (inactive images).
inline bool Same(double a, double b) { return (std::isnan(a) && std::isnan(b)) || a == b; }

inline void ExpectSameResults(const CalibResults& a, const CalibResults& b,
                              const std::string& what) {
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

}  // namespace mm::test
