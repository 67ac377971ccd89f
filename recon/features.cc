#include "recon/features.h"

#include <cmath>
#include <opencv2/features2d.hpp>
#include <opencv2/imgproc.hpp>

namespace mm {

std::string SiftOptions::Check() const {
  if (max_features < 0) return "max_features: must be >= 0";
  if (!(contrast_threshold > 0)) return "contrast_threshold: must be > 0";
  if (octave_layers < 1) return "octave_layers: must be >= 1";
  if (first_octave < -1 || first_octave > 2) return "first_octave: must be in [-1, 2]";
  return {};
}

Features ExtractSift(const cv::Mat& gray, const SiftOptions& options) {
  CV_Assert(gray.type() == CV_8UC1);
  auto sift = cv::SIFT::create(options.max_features, options.octave_layers,
                               options.contrast_threshold);
  Features out;
  if (options.first_octave < 0) {
    sift->detectAndCompute(gray, cv::noArray(), out.keypoints, out.descriptors);
    return out;
  }
  // OpenCV doubles its input (octave -1); feed it a 2^(k+1) smaller image so its first octave
  // is Lowe's octave k of the original, then map keypoints back to the original pixels.
  const double scale = std::ldexp(1.0, options.first_octave + 1);
  cv::Mat small;
  cv::resize(gray, small, cv::Size(), 1.0 / scale, 1.0 / scale, cv::INTER_AREA);
  sift->detectAndCompute(small, cv::noArray(), out.keypoints, out.descriptors);
  const auto s = static_cast<float>(scale);
  for (cv::KeyPoint& k : out.keypoints) {
    // Pixel centres: x_full = (x_small + 0.5) * s - 0.5.
    k.pt = cv::Point2f((k.pt.x + 0.5f) * s - 0.5f, (k.pt.y + 0.5f) * s - 0.5f);
    k.size *= s;
  }
  return out;
}

}  // namespace mm
