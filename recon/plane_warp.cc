// The sweep's warp (recon/plane_warp.h): one source compiled for every Highway target; the
// vector loop runs over the pixels of a row, its tail uses the scalar formula.

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <span>

#include "recon/plane_warp.h"

#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "recon/plane_warp.cc"
#include <hwy/foreach_target.h>  // IWYU pragma: keep
#include <hwy/highway.h>

#ifndef MM_RECON_PLANE_WARP_SHARED
#define MM_RECON_PLANE_WARP_SHARED
namespace mm::plane_warp_detail {

// One row's homogeneous pixel h(x) = slope * x + start, in float.
struct Row {
  float slope[3];
  float start[3];
};

inline Row RowOf(const Eigen::Matrix3d& H, int y) {
  Row r{};
  for (int i = 0; i < 3; ++i) {
    r.slope[i] = static_cast<float>(H(i, 0));
    r.start[i] = static_cast<float>(H(i, 1) * y + H(i, 2));
  }
  return r;
}

constexpr float kMinZ = 1e-6f;

// The sample at pixel x of a row: the formula the vector loop follows step by step.
inline float WarpAt(const float* view, float width_f, float last_x, float last_y, const Row& r,
                    int x) {
  const auto xf = static_cast<float>(x);
  const float hx = r.slope[0] * xf + r.start[0];
  const float hy = r.slope[1] * xf + r.start[1];
  const float hz = r.slope[2] * xf + r.start[2];
  const bool valid = hz > kMinZ;
  float u = valid ? hx / hz : 0.0f;
  float v = valid ? hy / hz : 0.0f;
  u = std::min(std::max(u, 0.0f), last_x);
  v = std::min(std::max(v, 0.0f), last_y);
  const float fu = std::floor(u), fv = std::floor(v);
  const float ax = u - fu, ay = v - fv;
  const float step_x = std::min(fu + 1.0f, last_x) - fu;
  const float step_y = (std::min(fv + 1.0f, last_y) - fv) * width_f;
  const float i00 = fv * width_f + fu;
  const float p00 = view[static_cast<int32_t>(i00)];
  const float p01 = view[static_cast<int32_t>(i00 + step_x)];
  const float p10 = view[static_cast<int32_t>(i00 + step_y)];
  const float p11 = view[static_cast<int32_t>(i00 + step_y + step_x)];
  const float top = p00 + ax * (p01 - p00);
  const float bottom = p10 + ax * (p11 - p10);
  return top + ay * (bottom - top);
}

inline bool Fits(size_t view, int width, int height, size_t out) {
  if (width < 1 || height < 1) return false;
  const auto n = static_cast<size_t>(width) * static_cast<size_t>(height);
  return n < (size_t{1} << 24) && view == n && out == n;
}

}  // namespace mm::plane_warp_detail
#endif  // MM_RECON_PLANE_WARP_SHARED

HWY_BEFORE_NAMESPACE();
namespace mm::HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

// Declared for -Wmissing-declarations; exported below.
int64_t WarpByHomographyImpl(const float* view, int width, int height, const Eigen::Matrix3d& H,
                             float* out);

int64_t WarpByHomographyImpl(const float* view, int width, int height, const Eigen::Matrix3d& H,
                             float* out) {
  const hn::ScalableTag<float> df;
  const hn::RebindToSigned<decltype(df)> di;
  const int lanes = static_cast<int>(hn::Lanes(df));
  const auto width_f = static_cast<float>(width);
  const auto last_x = static_cast<float>(width - 1), last_y = static_cast<float>(height - 1);
  const auto v_width = hn::Set(df, width_f), v_last_x = hn::Set(df, last_x);
  const auto v_last_y = hn::Set(df, last_y), v_one = hn::Set(df, 1.0f);
  const auto v_min_z = hn::Set(df, plane_warp_detail::kMinZ), v_zero = hn::Zero(df);
  for (int y = 0; y < height; ++y) {
    const plane_warp_detail::Row r = plane_warp_detail::RowOf(H, y);
    const auto sx = hn::Set(df, r.slope[0]), sy = hn::Set(df, r.slope[1]);
    const auto sz = hn::Set(df, r.slope[2]);
    const auto ox = hn::Set(df, r.start[0]), oy = hn::Set(df, r.start[1]);
    const auto oz = hn::Set(df, r.start[2]);
    float* out_row = out + static_cast<size_t>(y) * width;
    int x = 0;
    for (; x + lanes <= width; x += lanes) {
      const auto xf = hn::Iota(df, static_cast<float>(x));
      const auto hx = hn::Add(hn::Mul(sx, xf), ox);
      const auto hy = hn::Add(hn::Mul(sy, xf), oy);
      const auto hz = hn::Add(hn::Mul(sz, xf), oz);
      const auto valid = hn::Gt(hz, v_min_z);
      // Masked lanes may divide by zero; the select drops what they give.
      auto u = hn::IfThenElseZero(valid, hn::Div(hx, hz));
      auto v = hn::IfThenElseZero(valid, hn::Div(hy, hz));
      u = hn::Min(hn::Max(u, v_zero), v_last_x);
      v = hn::Min(hn::Max(v, v_zero), v_last_y);
      const auto fu = hn::Floor(u), fv = hn::Floor(v);
      const auto ax = hn::Sub(u, fu), ay = hn::Sub(v, fv);
      const auto step_x = hn::Sub(hn::Min(hn::Add(fu, v_one), v_last_x), fu);
      const auto step_y = hn::Mul(hn::Sub(hn::Min(hn::Add(fv, v_one), v_last_y), fv), v_width);
      const auto i00 = hn::Add(hn::Mul(fv, v_width), fu);
      const auto p00 = hn::GatherIndex(df, view, hn::ConvertTo(di, i00));
      const auto p01 = hn::GatherIndex(df, view, hn::ConvertTo(di, hn::Add(i00, step_x)));
      const auto p10 = hn::GatherIndex(df, view, hn::ConvertTo(di, hn::Add(i00, step_y)));
      const auto p11 =
          hn::GatherIndex(df, view, hn::ConvertTo(di, hn::Add(hn::Add(i00, step_y), step_x)));
      const auto top = hn::Add(p00, hn::Mul(ax, hn::Sub(p01, p00)));
      const auto bottom = hn::Add(p10, hn::Mul(ax, hn::Sub(p11, p10)));
      hn::StoreU(hn::Add(top, hn::Mul(ay, hn::Sub(bottom, top))), df, out_row + x);
    }
    for (; x < width; ++x) {
      out_row[x] = plane_warp_detail::WarpAt(view, width_f, last_x, last_y, r, x);
    }
  }
  return HWY_TARGET;
}

}  // namespace mm::HWY_NAMESPACE
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace mm {

HWY_EXPORT(WarpByHomographyImpl);

bool WarpByHomography(std::span<const float> view, int width, int height,
                      const Eigen::Matrix3d& view_from_a, std::span<float> out,
                      int64_t* target_used) {
  if (!plane_warp_detail::Fits(view.size(), width, height, out.size())) return false;
  const int64_t target = HWY_DYNAMIC_DISPATCH(WarpByHomographyImpl)(view.data(), width, height,
                                                                    view_from_a, out.data());
  if (target_used != nullptr) *target_used = target;
  return true;
}

bool WarpByHomographyScalar(std::span<const float> view, int width, int height,
                            const Eigen::Matrix3d& view_from_a, std::span<float> out) {
  if (!plane_warp_detail::Fits(view.size(), width, height, out.size())) return false;
  const auto width_f = static_cast<float>(width);
  const auto last_x = static_cast<float>(width - 1), last_y = static_cast<float>(height - 1);
  for (int y = 0; y < height; ++y) {
    const plane_warp_detail::Row r = plane_warp_detail::RowOf(view_from_a, y);
    float* out_row = out.data() + static_cast<size_t>(y) * width;
    for (int x = 0; x < width; ++x) {
      out_row[x] = plane_warp_detail::WarpAt(view.data(), width_f, last_x, last_y, r, x);
    }
  }
  return true;
}

}  // namespace mm
#endif  // HWY_ONCE
