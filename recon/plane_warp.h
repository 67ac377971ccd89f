#pragma once
// The plane sweep's warp (recon/dense.h): a view resampled into A through a plane's homography
// h = H (x, y, 1) of A's pixel, bilinear, borders replicated: what cv::warpPerspective gives with
// WARP_INVERSE_MAP, INTER_LINEAR and BORDER_REPLICATE, but at the exact sub-pixel position
// (OpenCV rounds it to 1/32 pixel) and without its per-call map. h is affine along a row, so a
// row costs two adds and two divisions per pixel before the four taps. The rows run with Google
// Highway on every target in HWY_TARGETS (gathers for the taps), beside a scalar reference with
// the same operations in the same order, so both give the same images (no fused multiply-add
// on either side).
//
// Thread-safety: pure functions; reentrant.

#include <Eigen/Core>
#include <cstdint>
#include <span>

namespace mm {

/// `view` (width x height floats, row-major) sampled at H (x, y, 1) for each pixel (x, y) of
/// `out` (the same size). Where the homogeneous z is not positive, the sample is view(0, 0).
/// Returns false when the sizes do not fit (width, height >= 1, spans of width x height, and
/// fewer than 2^24 pixels: tap indices are computed exactly in float). `target_used`: the
/// Highway target that ran.
bool WarpByHomography(std::span<const float> view, int width, int height,
                      const Eigen::Matrix3d& view_from_a, std::span<float> out,
                      int64_t* target_used = nullptr);

/// The scalar reference.
bool WarpByHomographyScalar(std::span<const float> view, int width, int height,
                            const Eigen::Matrix3d& view_from_a, std::span<float> out);

}  // namespace mm
