#pragma once
// The plane sweep's matching cost (recon/dense.h) for one plane, fused into one pass: box sums
// of the warped view w, w^2 and a*w over A's (2r+1)^2 windows (borders reflected as OpenCV's
// BORDER_REFLECT), then the zero-mean normalized cross-correlation
//   ZNCC = (mean(aw) - mean(a) mean(w)) / sqrt(var(a) var(w))
// as a fixed-point cost round(scale * (1 - ZNCC)) in 0..2 scale. Summing windows as running
// column sums plus a horizontal window replaces three box filters and a dozen full-image
// arithmetic passes (Faugeras et al. 1993 compute correlation by box sums the same way). The
// rows run with Google Highway on every target in HWY_TARGETS (chosen at run time, as
// recon/sgm.h), beside a scalar reference with the same operations in the same order, so both
// give the same costs (no fused multiply-add on either side).
//
// Thread-safety: pure functions; reentrant (scratch rows are kept per thread).

#include <cstdint>
#include <opencv2/core.hpp>
#include <span>

namespace mm {

/// A's side of the windows, computed once per sweep: grey levels `a`, window means `mean_a` and
/// variances `var_a` (float, row-major, width x height each).
struct ZnccWindowsA {
  std::span<const float> a, mean_a, var_a;
  int width = 0;
  int height = 0;
  int radius = 3;
};

/// A's side with its images owned: the grey levels and their window means and variances
/// (OpenCV's normalized box filters, borders reflected as the cost's own sums).
struct ZnccStatsA {
  cv::Mat a, mean_a, var_a;  ///< CV_32F, continuous.
  int radius = 3;
  /// The spans PlaneZnccCost takes; valid while this lives.
  [[nodiscard]] ZnccWindowsA Windows() const;
};

/// `a`: grey levels, CV_32F.
ZnccStatsA ComputeZnccStatsA(const cv::Mat& a, int radius);

/// `view_in_a`: the view warped into A (width x height floats). A view window whose variance is
/// below `min_var` (no texture) has ZNCC 0. Writes `cost` (width x height). Returns false when
/// the sizes do not fit (radius >= 1, width and height > 2 radius). `target_used`: the Highway
/// target that ran.
bool PlaneZnccCost(const ZnccWindowsA& a, std::span<const float> view_in_a, float min_var,
                   int cost_scale, std::span<uint16_t> cost, int64_t* target_used = nullptr);

/// The scalar reference.
bool PlaneZnccCostScalar(const ZnccWindowsA& a, std::span<const float> view_in_a, float min_var,
                         int cost_scale, std::span<uint16_t> cost);

}  // namespace mm
