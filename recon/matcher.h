#pragma once
// Brute-force L2 matching of SIFT descriptors with Lowe's ratio test and a mutual check,
// vectorized with Google Highway (run-time dispatch; recon/matcher.cc).
//
// Thread-safety: pure functions; reentrant.

#include <cstdint>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

namespace mm {

struct MatchOptions {
  double ratio = 0.8;  ///< Lowe's ratio test (0.6 as in the thesis this project follows).
  bool mutual = true;  ///< Keep a match only if it is also the best match in reverse.
  [[nodiscard]] std::string Check() const;
};

struct Match {
  int index_a = 0;
  int index_b = 0;
  float distance = 0.0f;
};

/// Brute-force L2 matching with the ratio test (d1 < ratio * d2) and optional mutual check
/// (i's best in B has i as its best in A), Highway SIMD with run-time dispatch. Descriptors
/// are rounded to integers in [0, 255] (SIFT's already are), which makes the result exactly
/// that of MatchDescriptorsScalar. Ties: the lowest index wins. `target_used` (optional)
/// receives the Highway target that ran (e.g. HWY_AVX2).
std::vector<Match> MatchDescriptors(const cv::Mat& descriptors_a, const cv::Mat& descriptors_b,
                                    const MatchOptions& options, int64_t* target_used = nullptr);

/// The scalar reference of MatchDescriptors (same rounding, order and tie rule).
std::vector<Match> MatchDescriptorsScalar(const cv::Mat& descriptors_a,
                                          const cv::Mat& descriptors_b,
                                          const MatchOptions& options);

}  // namespace mm
