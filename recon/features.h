#pragma once
// SIFT features (Lowe, IJCV 2004) through OpenCV, and ratio-test matching.
//
// Thread-safety: pure functions; reentrant.

#include <opencv2/core.hpp>
#include <string>
#include <vector>

namespace mm {

struct SiftOptions {
  int max_features = 4000;          ///< Keep the strongest N (0 = all).
  double contrast_threshold = 0.04; ///< Lowe's D(x) threshold, as OpenCV's.
  int octave_layers = 3;            ///< Scales per octave.
  [[nodiscard]] std::string Check() const;
};

struct Features {
  std::vector<cv::KeyPoint> keypoints;
  cv::Mat descriptors;  ///< CV_32F, one 128-d row per keypoint.
};

/// SIFT on an 8-bit gray image.
Features ExtractSift(const cv::Mat& gray, const SiftOptions& options);

struct MatchOptions {
  double ratio = 0.8;   ///< Lowe's ratio test (0.6 as in the thesis this project follows).
  bool mutual = true;   ///< Keep a match only if it is also the best match in reverse.
  [[nodiscard]] std::string Check() const;
};

struct Match {
  int index_a = 0;
  int index_b = 0;
  float distance = 0.0f;
};

/// Brute-force L2 matching with the ratio test and optional mutual check.
std::vector<Match> MatchDescriptors(const cv::Mat& descriptors_a, const cv::Mat& descriptors_b,
                                    const MatchOptions& options);

}  // namespace mm
