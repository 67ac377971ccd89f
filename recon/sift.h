#pragma once
// Our own SIFT (Lowe, IJCV 2004), the second implementation behind ExtractSift
// (SiftOptions::impl = SiftImpl::kOwn). Same scale space and keypoint convention as OpenCV 4.6's
// cv::SIFT; the hot kernels (separable Gaussian blur, DoG, the 3x3x3 extremum test, gradient
// magnitude/orientation, descriptor sample weights) are written once with Google Highway and
// dispatched at run time (SSE4/AVX2/AVX-512 on x86, NEON on aarch64), each with a scalar
// reference for the tests.
//
// Thread-safety: pure functions; reentrant.

#include <hwy/aligned_allocator.h>
#include <cstdint>
#include <vector>

#include "recon/features.h"

namespace mm::sift {

/// A float image, rows contiguous (stride = w).
struct Plane {
  int w = 0;
  int h = 0;
  hwy::AlignedFreeUniquePtr<float[]> px;
  size_t capacity = 0;  ///< Allocated floats (Resize reuses them when large enough).
  Plane() = default;
  Plane(int width, int height);
  void Resize(int width, int height);
  float* Row(int y) { return px.get() + static_cast<size_t>(y) * static_cast<size_t>(w); }
  const float* Row(int y) const {
    return px.get() + static_cast<size_t>(y) * static_cast<size_t>(w);
  }
  float At(int y, int x) const { return Row(y)[x]; }
};

/// The right half k[0..r] of a normalized Gaussian, r = radius as OpenCV's GaussianBlur picks it
/// for float images (kernel size round(8 sigma + 1) | 1).
std::vector<float> GaussianHalfKernel(double sigma);

/// Separable convolution with the symmetric kernel `half` (k[0..r]), borders reflected as
/// OpenCV's BORDER_REFLECT_101 (also for r larger than the image). `dst` is resized. With
/// `dog`, also writes dst - src there (the next difference of Gaussians, in the same pass).
/// Returns the Highway target that ran.
int64_t Blur(const Plane& src, const std::vector<float>& half, Plane* dst, Plane* dog = nullptr);
void BlurScalar(const Plane& src, const std::vector<float>& half, Plane* dst);

/// out = a - b (same size; `out` is resized).
int64_t Subtract(const Plane& a, const Plane& b, Plane* out);

/// Lowe's 3x3x3 test on DoG layer `cur` (Sec. 3): pixels with |D| > threshold that are >= (for
/// D > 0) or <= (D < 0) all 26 neighbours, at least `border` pixels from the edges. Appends
/// y * w + x in row-major order.
int64_t FindExtrema(const Plane& prev, const Plane& cur, const Plane& next, float threshold,
                    int border, std::vector<int>* out);
void FindExtremaScalar(const Plane& prev, const Plane& cur, const Plane& next, float threshold,
                       int border, std::vector<int>* out);

/// Central-difference gradient (dx = I(x+1) - I(x-1), dy = I(y-1) - I(y+1), as OpenCV) as
/// magnitude and orientation in degrees [0, 360) (FastAtan2Deg); 0 on the one-pixel border.
int64_t GradientPolar(const Plane& img, Plane* mag, Plane* ori);
void GradientPolarScalar(const Plane& img, Plane* mag, Plane* ori);

/// atan2(y, x) in degrees in [0, 360): octant reduction and the degree-9 odd polynomial of
/// Abramowitz & Stegun 4.4.49 (|error| < 1e-5 rad).
float FastAtan2Deg(float y, float x);

/// The samples of one descriptor window (Lowe 2004 Sec. 6.1) from precomputed gradient maps:
/// for every pixel of the square of half-size `radius` around (cx, cy) (integer centre) that
/// falls inside the 4x4 grid after rotation, the lower corner of its trilinear cell as a flat
/// index into a 6x6x10 histogram (row bin r0 in [-1, 3] at (r0 + 1) * 60, column bin c0 at
/// (c0 + 1) * 10, orientation bin o0 in [0, 8) relative to `ori_deg`, 45 degrees each), the
/// three fractional parts and the magnitude times the Gaussian window (sigma = half the grid).
/// `dx0`/`dy0` is the keypoint's sub-pixel offset from (cx, cy).
struct DescriptorWindow {
  int cx = 0, cy = 0, radius = 0;
  float dx0 = 0, dy0 = 0;
  float cos_t = 1, sin_t = 0;  ///< cos/sin of the angle divided by the bin width (pixels).
  float ori_deg = 0;
};
struct DescriptorSamples {
  std::vector<int32_t> bin;
  std::vector<float> rfrac, cfrac, ofrac, mag;
  size_t n = 0;
};
int64_t CollectDescriptorSamples(const Plane& mag, const Plane& ori, const DescriptorWindow& win,
                                 DescriptorSamples* out);
void CollectDescriptorSamplesScalar(const Plane& mag, const Plane& ori, const DescriptorWindow& win,
                                    DescriptorSamples* out);

/// The whole detector and descriptor (called by ExtractSift for SiftImpl::kOwn).
Features ExtractSiftOwn(const cv::Mat& gray, const SiftOptions& options);
/// Frees the calling thread's workspace (ReleaseSiftWorkspace in recon/features.h).
void ReleaseWorkspace();

}  // namespace mm::sift
