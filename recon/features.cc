#include "recon/features.h"

#include <cmath>
#include <opencv2/features2d.hpp>
#include <opencv2/imgproc.hpp>

#include "recon/sift.h"

namespace mm {

std::string SiftImplName(SiftImpl impl) { return impl == SiftImpl::kOwn ? "own" : "opencv"; }

std::optional<SiftImpl> ParseSiftImpl(const std::string& name) {
  if (name == "own") return SiftImpl::kOwn;
  if (name == "opencv") return SiftImpl::kOpenCv;
  return std::nullopt;
}

std::string SiftOptions::Check() const {
  if (max_features < 0) return "max_features: must be >= 0";
  if (!(contrast_threshold > 0)) return "contrast_threshold: must be > 0";
  if (octave_layers < 1) return "octave_layers: must be >= 1";
  if (first_octave < -1 || first_octave > 2) return "first_octave: must be in [-1, 2]";
  if (!(resize_factor > 0 && resize_factor <= 1)) return "resize_factor: must be in (0, 1]";
  return {};
}

void ReleaseSiftWorkspace() { sift::ReleaseWorkspace(); }

Features ExtractSift(const cv::Mat& gray, const SiftOptions& options) {
  CV_Assert(gray.type() == CV_8UC1);
  if (options.impl == SiftImpl::kOwn) return sift::ExtractSiftOwn(gray, options);
  auto sift =
      cv::SIFT::create(options.max_features, options.octave_layers, options.contrast_threshold);
  Features out;
  if (options.first_octave < 0 && !(options.resize_factor < 1.0)) {
    sift->detectAndCompute(gray, cv::noArray(), out.keypoints, out.descriptors);
    return out;
  }
  // OpenCV doubles its input (octave -1); feed it a 2^(k+1) smaller image so its first octave
  // is Lowe's octave k of the original (times resize_factor), then map keypoints back to the
  // original pixels.
  const double scale = std::ldexp(1.0, options.first_octave + 1) / options.resize_factor;
  cv::Mat small;
  cv::resize(gray, small, cv::Size(), 1.0 / scale, 1.0 / scale, cv::INTER_AREA);
  sift->detectAndCompute(small, cv::noArray(), out.keypoints, out.descriptors);
  // The exact per-axis factors (the resized size is rounded).
  const auto sx = static_cast<float>(gray.cols) / static_cast<float>(small.cols);
  const auto sy = static_cast<float>(gray.rows) / static_cast<float>(small.rows);
  for (cv::KeyPoint& k : out.keypoints) {
    // Pixel centres: x_full = (x_small + 0.5) * s - 0.5.
    k.pt = cv::Point2f((k.pt.x + 0.5f) * sx - 0.5f, (k.pt.y + 0.5f) * sy - 0.5f);
    k.size *= 0.5f * (sx + sy);
  }
  return out;
}

}  // namespace mm
