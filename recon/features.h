#pragma once
// SIFT features (Lowe, IJCV 2004): our own Highway implementation (recon/sift.h, the default)
// or OpenCV 4.6's cv::SIFT, chosen by SiftOptions::impl. Matching is recon/matcher.h (included
// here, as every caller of ExtractSift matches).
//
// Thread-safety: pure functions; reentrant.

#include <cstdint>
#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <vector>

#include "recon/matcher.h"

namespace mm {

/// Which SIFT runs: OpenCV 4.6's cv::SIFT, or ours (recon/sift.h: same scale space and keypoint
/// convention, Highway kernels; ~25 % faster per image on x86 with the same accuracy within
/// RANSAC-seed noise, docs/recon_tuning.md).
enum class SiftImpl { kOpenCv, kOwn };

/// "opencv" or "own", the names the config file and `monomesh eval` use.
std::string SiftImplName(SiftImpl impl);
/// The implementation named `name`, or nullopt for any other text.
std::optional<SiftImpl> ParseSiftImpl(const std::string& name);

struct SiftOptions {
  SiftImpl impl = SiftImpl::kOwn;
  int max_features = 4000;           ///< Keep the strongest N (0 = all).
  double contrast_threshold = 0.04;  ///< Lowe's D(x) threshold, as OpenCV's.
  int octave_layers = 3;             ///< Scales per octave.
  /// Lowe's first octave: -1 doubles the image (OpenCV's fixed choice), 0 starts at full
  /// resolution, 1 at half. OpenCV 4.6 always doubles, so with kOpenCv for first_octave = k >= 0
  /// the image is downscaled by 2^(k+1) before and keypoints are scaled back after; kOwn starts
  /// its pyramid at octave k natively.
  int first_octave = -1;
  /// The image is resized by this factor first (INTER_AREA) and keypoints are mapped back:
  /// between octaves, e.g. 0.75 with first_octave -1 starts at 1.5x the original resolution
  /// (0.56x the pixels of OpenCV's doubled image). 1 = off.
  double resize_factor = 1.0;
  [[nodiscard]] std::string Check() const;
};

struct Features {
  std::vector<cv::KeyPoint> keypoints;
  cv::Mat descriptors;  ///< CV_32F, one 128-d row per keypoint.
};

/// SIFT on an 8-bit gray image (options.impl chooses the implementation).
Features ExtractSift(const cv::Mat& gray, const SiftOptions& options);

/// Frees the calling thread's SIFT workspace (the own SIFT keeps its pyramid, tens of MB at
/// 640x480, between calls); the next ExtractSift on the thread allocates it again.
void ReleaseSiftWorkspace();

}  // namespace mm
