#include "recon/features.h"

#include <opencv2/features2d.hpp>

namespace mm {

std::string SiftOptions::Check() const {
  if (max_features < 0) return "max_features: must be >= 0";
  if (!(contrast_threshold > 0)) return "contrast_threshold: must be > 0";
  if (octave_layers < 1) return "octave_layers: must be >= 1";
  return {};
}

std::string MatchOptions::Check() const {
  if (!(ratio > 0 && ratio <= 1)) return "ratio: must be in (0, 1]";
  return {};
}

Features ExtractSift(const cv::Mat& gray, const SiftOptions& options) {
  CV_Assert(gray.type() == CV_8UC1);
  auto sift = cv::SIFT::create(options.max_features, options.octave_layers,
                               options.contrast_threshold);
  Features out;
  sift->detectAndCompute(gray, cv::noArray(), out.keypoints, out.descriptors);
  return out;
}

std::vector<Match> MatchDescriptors(const cv::Mat& descriptors_a, const cv::Mat& descriptors_b,
                                    const MatchOptions& options) {
  std::vector<Match> matches;
  if (descriptors_a.rows < 2 || descriptors_b.rows < 2) return matches;
  cv::BFMatcher matcher(cv::NORM_L2);
  std::vector<std::vector<cv::DMatch>> ab;
  matcher.knnMatch(descriptors_a, descriptors_b, ab, 2);
  std::vector<int> best_ba;
  if (options.mutual) {
    std::vector<std::vector<cv::DMatch>> ba;
    matcher.knnMatch(descriptors_b, descriptors_a, ba, 1);
    best_ba.assign(static_cast<size_t>(descriptors_b.rows), -1);
    for (const auto& m : ba) {
      if (!m.empty()) best_ba[static_cast<size_t>(m[0].queryIdx)] = m[0].trainIdx;
    }
  }
  for (const auto& knn : ab) {
    if (knn.size() < 2) continue;
    if (knn[0].distance >= options.ratio * knn[1].distance) continue;
    if (options.mutual && best_ba[static_cast<size_t>(knn[0].trainIdx)] != knn[0].queryIdx) {
      continue;
    }
    matches.push_back({knn[0].queryIdx, knn[0].trainIdx, knn[0].distance});
  }
  return matches;
}

}  // namespace mm
