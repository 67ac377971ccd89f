// The fused plane cost (recon/zncc.h): one source compiled for every Highway target; the vector
// loops run over the pixels of a row, their tails use the scalar formulas.

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <opencv2/imgproc.hpp>
#include <span>
#include <vector>

#include "recon/zncc.h"

#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "recon/zncc.cc"
#include <hwy/foreach_target.h>  // IWYU pragma: keep
#include <hwy/highway.h>

#ifndef MM_RECON_ZNCC_SHARED
#define MM_RECON_ZNCC_SHARED
namespace mm::zncc_detail {

// OpenCV's BORDER_REFLECT: fedcba|abcdefgh|hgfedcb.
inline int Reflect(int i, int n) { return i < 0 ? -i - 1 : (i >= n ? 2 * n - i - 1 : i); }

inline bool Fits(const ZnccWindowsA& a, size_t view, size_t cost) {
  const int r = a.radius;
  if (r < 1 || a.width <= 2 * r || a.height <= 2 * r) return false;
  const size_t n = static_cast<size_t>(a.width) * a.height;
  return a.a.size() == n && a.mean_a.size() == n && a.var_a.size() == n && view == n && cost == n;
}

// Column sums of w, w^2 and a w over rows y - r .. y + r (reflected) at pixel x, in that order.
// Products are separate statements so that no compiler fuses them into a multiply-add.
inline void ColumnSumsAt(const ZnccWindowsA& a, const float* view, int y, int x, float* sw,
                         float* sww, float* saw) {
  float s = 0, ss = 0, as = 0;
  for (int k = -a.radius; k <= a.radius; ++k) {
    const size_t i = static_cast<size_t>(Reflect(y + k, a.height)) * a.width + x;
    const float w = view[i];
    const float ww = w * w;
    const float aw = a.a[i] * w;
    s = s + w;
    ss = ss + ww;
    as = as + aw;
  }
  *sw = s;
  *sww = ss;
  *saw = as;
}

// Fills the `radius` entries either side of a padded row of `width` values (reflected).
inline void PadReflect(float* padded, int width, int radius) {
  for (int j = 0; j < radius; ++j) {
    padded[radius - 1 - j] = padded[radius + j];
    padded[radius + width + j] = padded[radius + width - 1 - j];
  }
}

// The window sum at x of a padded row: padded[x] + ... + padded[x + 2 r], in that order.
inline float WindowSumAt(const float* padded, int x, int radius) {
  float s = padded[x];
  for (int k = 1; k <= 2 * radius; ++k) s = s + padded[x + k];
  return s;
}

// The cost from the window sums (the formula of zncc.h), as the vector code computes it.
inline uint16_t CostFromSums(float sw, float sww, float saw, float mean_a, float var_a, float inv_n,
                             float min_var, float scale) {
  const float mean_w = sw * inv_n;
  const float mean_ww = sww * inv_n;
  const float mean_aw = saw * inv_n;
  const float mean_w2 = mean_w * mean_w;
  const float var_w = mean_ww - mean_w2;
  const float mean_a_w = mean_a * mean_w;
  const float numerator = mean_aw - mean_a_w;
  const float variances = var_a * var_w;
  const float denominator = std::sqrt(std::max(variances, 1e-12f));
  float zncc = numerator / denominator;
  if (var_w < min_var) zncc = 0;
  const float scaled = scale * zncc;
  const float cost = std::nearbyint(scale - scaled);
  return static_cast<uint16_t>(std::clamp(cost, 0.0f, 2 * scale));
}

// Scratch rows (padded column sums), kept per thread.
struct Rows {
  std::vector<float> sw, sww, saw;
  void Resize(int width, int radius) {
    const size_t n = static_cast<size_t>(width) + 2 * static_cast<size_t>(radius);
    sw.resize(n);
    sww.resize(n);
    saw.resize(n);
  }
};

inline Rows& ThreadRows() {
  thread_local Rows rows;
  return rows;
}

}  // namespace mm::zncc_detail
#endif  // MM_RECON_ZNCC_SHARED

HWY_BEFORE_NAMESPACE();
namespace mm::HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

// Declared for -Wmissing-declarations; exported below.
int64_t PlaneZnccCostImpl(const ZnccWindowsA& a, const float* view, float min_var, int cost_scale,
                          uint16_t* cost);

int64_t PlaneZnccCostImpl(const ZnccWindowsA& a, const float* view, float min_var, int cost_scale,
                          uint16_t* cost) {
  const hn::ScalableTag<float> df;
  const hn::Rebind<int32_t, decltype(df)> di;
  const hn::Rebind<uint16_t, decltype(df)> du16;
  const int lanes = static_cast<int>(hn::Lanes(df));
  const int width = a.width, r = a.radius;
  const float inv_n = 1.0f / static_cast<float>((2 * r + 1) * (2 * r + 1));
  const auto scale = static_cast<float>(cost_scale);
  const auto v_inv_n = hn::Set(df, inv_n), v_min_var = hn::Set(df, min_var);
  const auto v_scale = hn::Set(df, scale), v_max = hn::Set(df, 2 * scale);
  const auto v_tiny = hn::Set(df, 1e-12f), v_zero = hn::Zero(df);
  zncc_detail::Rows& rows = zncc_detail::ThreadRows();
  rows.Resize(width, r);
  float* sw = rows.sw.data() + r;
  float* sww = rows.sww.data() + r;
  float* saw = rows.saw.data() + r;
  for (int y = 0; y < a.height; ++y) {
    // Column sums.
    int x = 0;
    for (; x + lanes <= width; x += lanes) {
      auto s = v_zero, ss = v_zero, as = v_zero;
      for (int k = -r; k <= r; ++k) {
        const size_t i = static_cast<size_t>(zncc_detail::Reflect(y + k, a.height)) * width + x;
        const auto w = hn::LoadU(df, view + i);
        s = hn::Add(s, w);
        ss = hn::Add(ss, hn::Mul(w, w));
        as = hn::Add(as, hn::Mul(hn::LoadU(df, a.a.data() + i), w));
      }
      hn::StoreU(s, df, sw + x);
      hn::StoreU(ss, df, sww + x);
      hn::StoreU(as, df, saw + x);
    }
    for (; x < width; ++x) zncc_detail::ColumnSumsAt(a, view, y, x, sw + x, sww + x, saw + x);
    zncc_detail::PadReflect(rows.sw.data(), width, r);
    zncc_detail::PadReflect(rows.sww.data(), width, r);
    zncc_detail::PadReflect(rows.saw.data(), width, r);
    // Window sums and the cost.
    const size_t row = static_cast<size_t>(y) * width;
    x = 0;
    for (; x + lanes <= width; x += lanes) {
      const float* pw = rows.sw.data() + x;
      const float* pww = rows.sww.data() + x;
      const float* paw = rows.saw.data() + x;
      auto s = hn::LoadU(df, pw), ss = hn::LoadU(df, pww), as = hn::LoadU(df, paw);
      for (int k = 1; k <= 2 * r; ++k) {
        s = hn::Add(s, hn::LoadU(df, pw + k));
        ss = hn::Add(ss, hn::LoadU(df, pww + k));
        as = hn::Add(as, hn::LoadU(df, paw + k));
      }
      const auto mean_w = hn::Mul(s, v_inv_n);
      const auto mean_ww = hn::Mul(ss, v_inv_n);
      const auto mean_aw = hn::Mul(as, v_inv_n);
      const auto var_w = hn::Sub(mean_ww, hn::Mul(mean_w, mean_w));
      const auto mean_a = hn::LoadU(df, a.mean_a.data() + row + x);
      const auto numerator = hn::Sub(mean_aw, hn::Mul(mean_a, mean_w));
      const auto variances = hn::Mul(hn::LoadU(df, a.var_a.data() + row + x), var_w);
      const auto denominator = hn::Sqrt(hn::Max(variances, v_tiny));
      auto zncc = hn::Div(numerator, denominator);
      zncc = hn::IfThenElse(hn::Lt(var_w, v_min_var), v_zero, zncc);
      const auto c =
          hn::Min(hn::Max(hn::Round(hn::Sub(v_scale, hn::Mul(v_scale, zncc))), v_zero), v_max);
      hn::StoreU(hn::DemoteTo(du16, hn::ConvertTo(di, c)), du16, cost + row + x);
    }
    for (; x < width; ++x) {
      cost[row + x] =
          zncc_detail::CostFromSums(zncc_detail::WindowSumAt(rows.sw.data(), x, r),
                                    zncc_detail::WindowSumAt(rows.sww.data(), x, r),
                                    zncc_detail::WindowSumAt(rows.saw.data(), x, r),
                                    a.mean_a[row + x], a.var_a[row + x], inv_n, min_var, scale);
    }
  }
  return HWY_TARGET;
}

}  // namespace mm::HWY_NAMESPACE
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace mm {

HWY_EXPORT(PlaneZnccCostImpl);

ZnccWindowsA ZnccStatsA::Windows() const {
  const size_t n = a.total();
  return {.a = {a.ptr<float>(), n},
          .mean_a = {mean_a.ptr<float>(), n},
          .var_a = {var_a.ptr<float>(), n},
          .width = a.cols,
          .height = a.rows,
          .radius = radius};
}

ZnccStatsA ComputeZnccStatsA(const cv::Mat& a, int radius) {
  ZnccStatsA out;
  out.a = a.isContinuous() ? a : a.clone();
  out.radius = radius;
  const cv::Size window(2 * radius + 1, 2 * radius + 1);
  cv::Mat mean_aa;
  cv::boxFilter(out.a, out.mean_a, CV_32F, window, cv::Point(-1, -1), true, cv::BORDER_REFLECT);
  cv::boxFilter(out.a.mul(out.a), mean_aa, CV_32F, window, cv::Point(-1, -1), true,
                cv::BORDER_REFLECT);
  out.var_a = mean_aa - out.mean_a.mul(out.mean_a);
  return out;
}

bool PlaneZnccCost(const ZnccWindowsA& a, std::span<const float> view_in_a, float min_var,
                   int cost_scale, std::span<uint16_t> cost, int64_t* target_used) {
  if (!zncc_detail::Fits(a, view_in_a.size(), cost.size()) || cost_scale < 1) return false;
  const int64_t target = HWY_DYNAMIC_DISPATCH(PlaneZnccCostImpl)(a, view_in_a.data(), min_var,
                                                                 cost_scale, cost.data());
  if (target_used != nullptr) *target_used = target;
  return true;
}

bool PlaneZnccCostScalar(const ZnccWindowsA& a, std::span<const float> view_in_a, float min_var,
                         int cost_scale, std::span<uint16_t> cost) {
  if (!zncc_detail::Fits(a, view_in_a.size(), cost.size()) || cost_scale < 1) return false;
  const int width = a.width, r = a.radius;
  const float inv_n = 1.0f / static_cast<float>((2 * r + 1) * (2 * r + 1));
  zncc_detail::Rows& rows = zncc_detail::ThreadRows();
  rows.Resize(width, r);
  for (int y = 0; y < a.height; ++y) {
    for (int x = 0; x < width; ++x) {
      zncc_detail::ColumnSumsAt(a, view_in_a.data(), y, x, &rows.sw[r + x], &rows.sww[r + x],
                                &rows.saw[r + x]);
    }
    zncc_detail::PadReflect(rows.sw.data(), width, r);
    zncc_detail::PadReflect(rows.sww.data(), width, r);
    zncc_detail::PadReflect(rows.saw.data(), width, r);
    const size_t row = static_cast<size_t>(y) * width;
    for (int x = 0; x < width; ++x) {
      cost[row + x] = zncc_detail::CostFromSums(zncc_detail::WindowSumAt(rows.sw.data(), x, r),
                                                zncc_detail::WindowSumAt(rows.sww.data(), x, r),
                                                zncc_detail::WindowSumAt(rows.saw.data(), x, r),
                                                a.mean_a[row + x], a.var_a[row + x], inv_n, min_var,
                                                static_cast<float>(cost_scale));
    }
  }
  return true;
}

}  // namespace mm
#endif  // HWY_ONCE
