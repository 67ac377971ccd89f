// The hot kernels of our SIFT (recon/sift.h) with Google Highway: one source compiled for every
// target in HWY_TARGETS, chosen at run time by HWY_DYNAMIC_DISPATCH (as recon/matcher.cc), plus
// their scalar references. Vector loops run over x; tails use the scalar formula.

#include <algorithm>
#include <cmath>
#include <cstring>
#include <vector>

#include "recon/sift.h"

#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "recon/sift_kernels.cc"
#include <hwy/foreach_target.h>  // IWYU pragma: keep
#include <hwy/highway.h>

// After highway.h, once per target.
#include <hwy/contrib/math/math-inl.h>

#ifndef MM_RECON_SIFT_KERNELS_SHARED
#define MM_RECON_SIFT_KERNELS_SHARED
namespace mm::sift::detail {

// BORDER_REFLECT_101 (gfedcb|abcdefgh|gfedcba), repeated for offsets beyond the image.
inline int Reflect101(int p, int n) {
  if (n == 1) return 0;
  while (p < 0 || p >= n) p = p < 0 ? -p : 2 * n - 2 - p;
  return p;
}

// Abramowitz & Stegun 4.4.49: atan(t) ~ t (a1 + a3 t^2 + ... + a9 t^8) on [0, 1].
constexpr float kAtan1 = 0.9998660f, kAtan3 = -0.3302995f, kAtan5 = 0.1801410f,
                kAtan7 = -0.0851330f, kAtan9 = 0.0208351f;
constexpr float kRadToDeg = 57.29577951308232f;

// Lowe 2004 Sec. 6.1: the descriptor window is a Gaussian with sigma = half the 4-bin grid,
// i.e. weight exp(-(u^2 + v^2) / 8) in bin units; 8 orientation bins of 45 degrees.
constexpr float kDescExpScale = -1.0f / 8.0f;
constexpr float kDescBinsPerDeg = 8.0f / 360.0f;

inline void DescriptorSample(const DescriptorWindow& win, float jj, float ii, float m, float o,
                             DescriptorSamples* out) {
  const float c_rot = jj * win.cos_t - ii * win.sin_t;
  const float r_rot = jj * win.sin_t + ii * win.cos_t;
  const float rbin = r_rot + 1.5f, cbin = c_rot + 1.5f;
  if (!(rbin > -1.0f && rbin < 4.0f && cbin > -1.0f && cbin < 4.0f)) return;
  float obin = (o - win.ori_deg) * kDescBinsPerDeg;
  if (obin < 0) obin += 8.0f;
  const float r0 = std::floor(rbin), c0 = std::floor(cbin), o0 = std::floor(obin);
  int oi = static_cast<int>(o0);
  if (oi >= 8) oi -= 8;
  const size_t k = out->n++;
  out->bin[k] = (static_cast<int>(r0) + 1) * 60 + (static_cast<int>(c0) + 1) * 10 + oi;
  out->rfrac[k] = rbin - r0;
  out->cfrac[k] = cbin - c0;
  out->ofrac[k] = obin - o0;
  out->mag[k] = m * std::exp((c_rot * c_rot + r_rot * r_rot) * kDescExpScale);
}

// The columns of row offset `ii` whose rotated position can fall inside the grid: both rotated
// coordinates within (-2.5, 2.5) bins, solved for the column offset, widened by one pixel
// (the exact test stays per sample). Narrows [*x0, *x1]; false if empty.
inline bool Slab(float a, float b, float* lo, float* hi) {
  // a jj + b in (-2.5, 2.5)
  if (std::abs(a) < 1e-9f) return std::abs(b) < 2.5f;
  float l = (-2.5f - b) / a, h = (2.5f - b) / a;
  if (l > h) std::swap(l, h);
  *lo = std::max(*lo, l);
  *hi = std::min(*hi, h);
  return true;
}

inline bool RowSpan(const DescriptorWindow& win, float ii, int* x0, int* x1) {
  float lo = -1e9f, hi = 1e9f;
  if (!Slab(win.cos_t, -ii * win.sin_t, &lo, &hi)) return false;
  if (!Slab(win.sin_t, ii * win.cos_t, &lo, &hi)) return false;
  const float base = static_cast<float>(win.cx) + win.dx0;
  *x0 = std::max(*x0, static_cast<int>(std::floor(base + lo)) - 1);
  *x1 = std::min(*x1, static_cast<int>(std::ceil(base + hi)) + 1);
  return *x0 <= *x1;
}

inline void ReserveSamples(const DescriptorWindow& win, DescriptorSamples* out) {
  const size_t cap = static_cast<size_t>(2 * win.radius + 1) * (2 * win.radius + 1) + 64;
  if (out->mag.size() < cap) {
    out->bin.resize(cap);
    out->rfrac.resize(cap);
    out->cfrac.resize(cap);
    out->ofrac.resize(cap);
    out->mag.resize(cap);
  }
  out->n = 0;
}

}  // namespace mm::sift::detail
#endif  // MM_RECON_SIFT_KERNELS_SHARED

HWY_BEFORE_NAMESPACE();
namespace mm::sift::HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

int64_t BlurImpl(const Plane& src, const std::vector<float>& half, Plane* dst, Plane* dog);
int64_t SubtractImpl(const Plane& a, const Plane& b, Plane* out);
int64_t FindExtremaImpl(const Plane& prev, const Plane& cur, const Plane& next, float threshold,
                        int border, std::vector<int>* out);
int64_t GradientPolarImpl(const Plane& img, Plane* mag, Plane* ori);
int64_t CollectDescriptorSamplesImpl(const Plane& mag, const Plane& ori,
                                     const DescriptorWindow& win, DescriptorSamples* out);

// Horizontal pass of each source row once, into a ring of 2r + 1 filtered rows (L2-resident),
// then the vertical pass from the ring: the source and destination are each streamed once
// (a vertical-first pass would stream 2r + 1 source rows at a time).
int64_t BlurImpl(const Plane& src, const std::vector<float>& half, Plane* dst, Plane* dog) {
  const hn::ScalableTag<float> d;
  const int n = static_cast<int>(hn::Lanes(d));
  const int w = src.w, h = src.h, r = static_cast<int>(half.size()) - 1;
  const int slots = 2 * r + 1;
  const size_t stride = (static_cast<size_t>(w) + 15) / 16 * 16;
  auto ring = hwy::AllocateAligned<float>(stride * static_cast<size_t>(slots));
  auto pad = hwy::AllocateAligned<float>(static_cast<size_t>(w + 2 * r + n));
  const float* k = half.data();
  auto filter_row = [&](int j) {
    const float* s = src.Row(j);
    float* t = pad.get() + r;
    std::memcpy(t, s, sizeof(float) * static_cast<size_t>(w));
    for (int i = 1; i <= r; ++i) {
      t[-i] = s[detail::Reflect101(-i, w)];
      t[w - 1 + i] = s[detail::Reflect101(w - 1 + i, w)];
    }
    float* out = ring.get() + static_cast<size_t>(j % slots) * stride;
    int x = 0;
    for (; x + n <= w; x += n) {
      auto acc = hn::Mul(hn::Set(d, k[0]), hn::LoadU(d, t + x));
      for (int i = 1; i <= r; ++i) {
        acc = hn::MulAdd(hn::Set(d, k[i]),
                         hn::Add(hn::LoadU(d, t + x - i), hn::LoadU(d, t + x + i)), acc);
      }
      hn::StoreU(acc, d, out + x);
    }
    for (; x < w; ++x) {
      float acc = k[0] * t[x];
      for (int i = 1; i <= r; ++i) acc += k[i] * (t[x - i] + t[x + i]);
      out[x] = acc;
    }
  };
  std::vector<const float*> rows(static_cast<size_t>(slots));
  int filtered = 0;  // Rows [0, filtered) have been filtered (the last 2r + 1 are in the ring).
  for (int y = 0; y < h; ++y) {
    for (; filtered <= std::min(h - 1, y + r); ++filtered) filter_row(filtered);
    for (int i = -r; i <= r; ++i) {
      rows[static_cast<size_t>(i + r)] =
          ring.get() + static_cast<size_t>(detail::Reflect101(y + i, h) % slots) * stride;
    }
    const float* const* rc = rows.data() + r;
    float* out = dst->Row(y);
    const float* sr = src.Row(y);
    float* dg = dog != nullptr ? dog->Row(y) : nullptr;
    int x = 0;
    for (; x + n <= w; x += n) {
      auto acc = hn::Mul(hn::Set(d, k[0]), hn::LoadU(d, rc[0] + x));
      for (int i = 1; i <= r; ++i) {
        acc = hn::MulAdd(hn::Set(d, k[i]),
                         hn::Add(hn::LoadU(d, rc[-i] + x), hn::LoadU(d, rc[i] + x)), acc);
      }
      hn::StoreU(acc, d, out + x);
      if (dg != nullptr) hn::StoreU(hn::Sub(acc, hn::LoadU(d, sr + x)), d, dg + x);
    }
    for (; x < w; ++x) {
      float acc = k[0] * rc[0][x];
      for (int i = 1; i <= r; ++i) acc += k[i] * (rc[-i][x] + rc[i][x]);
      out[x] = acc;
      if (dg != nullptr) dg[x] = acc - sr[x];
    }
  }
  return HWY_TARGET;
}

int64_t SubtractImpl(const Plane& a, const Plane& b, Plane* out) {
  const hn::ScalableTag<float> d;
  const size_t n = hn::Lanes(d);
  const size_t total = static_cast<size_t>(a.w) * static_cast<size_t>(a.h);
  const float* pa = a.px.get();
  const float* pb = b.px.get();
  float* po = out->px.get();
  size_t i = 0;
  for (; i + n <= total; i += n)
    hn::StoreU(hn::Sub(hn::LoadU(d, pa + i), hn::LoadU(d, pb + i)), d, po + i);
  for (; i < total; ++i) po[i] = pa[i] - pb[i];
  return HWY_TARGET;
}

// Staged test: |D| > threshold, then the 8 neighbours in the same layer, then the 18 in the
// layers above and below; most vectors leave after the first or second stage.
int64_t FindExtremaImpl(const Plane& prev, const Plane& cur, const Plane& next, float threshold,
                        int border, std::vector<int>* out) {
  const hn::ScalableTag<float> d;
  const int n = static_cast<int>(hn::Lanes(d));
  const int w = cur.w, h = cur.h;
  const auto thr = hn::Set(d, threshold);
  const auto zero = hn::Zero(d);
  uint8_t bits[64 / 8 + 8] = {};
  for (int y = border; y < h - border; ++y) {
    const float* c0 = cur.Row(y);
    const float* cu = cur.Row(y - 1);
    const float* cd = cur.Row(y + 1);
    int x = border;
    for (; x + n <= w - border; x += n) {
      const auto v = hn::LoadU(d, c0 + x);
      const auto strong = hn::Gt(hn::Abs(v), thr);
      if (hn::AllFalse(d, strong)) continue;
      auto mx = hn::Max(hn::LoadU(d, c0 + x - 1), hn::LoadU(d, c0 + x + 1));
      auto mn = hn::Min(hn::LoadU(d, c0 + x - 1), hn::LoadU(d, c0 + x + 1));
      for (const float* row : {cu, cd}) {
        const auto a = hn::LoadU(d, row + x - 1), b = hn::LoadU(d, row + x),
                   c = hn::LoadU(d, row + x + 1);
        mx = hn::Max(mx, hn::Max(a, hn::Max(b, c)));
        mn = hn::Min(mn, hn::Min(a, hn::Min(b, c)));
      }
      auto is_max = hn::And(strong, hn::And(hn::Gt(v, zero), hn::Ge(v, mx)));
      auto is_min = hn::And(strong, hn::And(hn::Lt(v, zero), hn::Le(v, mn)));
      if (hn::AllFalse(d, hn::Or(is_max, is_min))) continue;
      mx = zero;
      mn = zero;
      bool first = true;
      for (const Plane* p : {&prev, &next}) {
        for (int dy = -1; dy <= 1; ++dy) {
          const float* row = p->Row(y + dy) + x;
          const auto a = hn::LoadU(d, row - 1), b = hn::LoadU(d, row), c = hn::LoadU(d, row + 1);
          const auto rmx = hn::Max(a, hn::Max(b, c)), rmn = hn::Min(a, hn::Min(b, c));
          mx = first ? rmx : hn::Max(mx, rmx);
          mn = first ? rmn : hn::Min(mn, rmn);
          first = false;
        }
      }
      is_max = hn::And(is_max, hn::Ge(v, mx));
      is_min = hn::And(is_min, hn::Le(v, mn));
      const auto found = hn::Or(is_max, is_min);
      if (hn::AllFalse(d, found)) continue;
      hn::StoreMaskBits(d, found, bits);
      for (int i = 0; i < n; ++i) {
        if ((bits[i / 8] >> (i % 8)) & 1) out->push_back(y * w + x + i);
      }
    }
    for (; x < w - border; ++x) {
      const float v = c0[x];
      if (!(std::abs(v) > threshold)) continue;
      bool is_max = v > 0, is_min = v < 0;
      for (const Plane* p : {&prev, &cur, &next}) {
        for (int dy = -1; dy <= 1; ++dy) {
          const float* row = p->Row(y + dy);
          for (int dx = -1; dx <= 1; ++dx) {
            if (p == &cur && dy == 0 && dx == 0) continue;
            is_max = is_max && v >= row[x + dx];
            is_min = is_min && v <= row[x + dx];
          }
        }
      }
      if (is_max || is_min) out->push_back(y * w + x);
    }
  }
  return HWY_TARGET;
}

// atan2 in degrees, [0, 360): the same polynomial and octant steps as FastAtan2Deg.
template <class D, class V>
HWY_INLINE V Atan2Deg(D d, V y, V x) {
  const auto ax = hn::Abs(x), ay = hn::Abs(y);
  const auto hi = hn::Max(ax, ay), lo = hn::Min(ax, ay);
  const auto t = hn::Div(lo, hn::Max(hi, hn::Set(d, 1e-30f)));
  const auto s = hn::Mul(t, t);
  auto p = hn::MulAdd(s, hn::Set(d, detail::kAtan9), hn::Set(d, detail::kAtan7));
  p = hn::MulAdd(s, p, hn::Set(d, detail::kAtan5));
  p = hn::MulAdd(s, p, hn::Set(d, detail::kAtan3));
  p = hn::MulAdd(s, p, hn::Set(d, detail::kAtan1));
  auto a = hn::Mul(hn::Mul(t, p), hn::Set(d, detail::kRadToDeg));
  a = hn::IfThenElse(hn::Gt(ay, ax), hn::Sub(hn::Set(d, 90.0f), a), a);
  a = hn::IfThenElse(hn::Lt(x, hn::Zero(d)), hn::Sub(hn::Set(d, 180.0f), a), a);
  a = hn::IfThenElse(hn::Lt(y, hn::Zero(d)), hn::Sub(hn::Set(d, 360.0f), a), a);
  // 360 - 0 for tiny negative y: wrap into [0, 360).
  return hn::IfThenElse(hn::Ge(a, hn::Set(d, 360.0f)), hn::Sub(a, hn::Set(d, 360.0f)), a);
}

int64_t GradientPolarImpl(const Plane& img, Plane* mag, Plane* ori) {
  const hn::ScalableTag<float> d;
  const int n = static_cast<int>(hn::Lanes(d));
  const int w = img.w, h = img.h;
  std::memset(mag->Row(0), 0, sizeof(float) * static_cast<size_t>(w));
  std::memset(ori->Row(0), 0, sizeof(float) * static_cast<size_t>(w));
  std::memset(mag->Row(h - 1), 0, sizeof(float) * static_cast<size_t>(w));
  std::memset(ori->Row(h - 1), 0, sizeof(float) * static_cast<size_t>(w));
  for (int y = 1; y < h - 1; ++y) {
    const float* c = img.Row(y);
    const float* up = img.Row(y - 1);
    const float* dn = img.Row(y + 1);
    float* m = mag->Row(y);
    float* o = ori->Row(y);
    m[0] = o[0] = m[w - 1] = o[w - 1] = 0.0f;
    int x = 1;
    for (; x + n <= w - 1; x += n) {
      const auto dx = hn::Sub(hn::LoadU(d, c + x + 1), hn::LoadU(d, c + x - 1));
      const auto dy = hn::Sub(hn::LoadU(d, up + x), hn::LoadU(d, dn + x));
      hn::StoreU(hn::Sqrt(hn::MulAdd(dx, dx, hn::Mul(dy, dy))), d, m + x);
      hn::StoreU(Atan2Deg(d, dy, dx), d, o + x);
    }
    for (; x < w - 1; ++x) {
      const float dx = c[x + 1] - c[x - 1], dy = up[x] - dn[x];
      m[x] = std::sqrt(dx * dx + dy * dy);
      o[x] = FastAtan2Deg(dy, dx);
    }
  }
  return HWY_TARGET;
}

int64_t CollectDescriptorSamplesImpl(const Plane& mag, const Plane& ori,
                                     const DescriptorWindow& win, DescriptorSamples* out) {
  const hn::ScalableTag<float> d;
  const int n = static_cast<int>(hn::Lanes(d));
  detail::ReserveSamples(win, out);
  const int y0 = std::max(1, win.cy - win.radius), y1 = std::min(mag.h - 2, win.cy + win.radius);
  const int x0 = std::max(1, win.cx - win.radius), x1 = std::min(mag.w - 2, win.cx + win.radius);
  const auto cos_t = hn::Set(d, win.cos_t), sin_t = hn::Set(d, win.sin_t);
  const auto lo = hn::Set(d, -1.0f), hi = hn::Set(d, 4.0f), half = hn::Set(d, 1.5f);
  const auto ori0 = hn::Set(d, win.ori_deg), bins = hn::Set(d, detail::kDescBinsPerDeg);
  const auto eight = hn::Set(d, 8.0f), zero = hn::Zero(d),
             escale = hn::Set(d, detail::kDescExpScale);
  const hn::RebindToSigned<decltype(d)> di;
  const auto i1 = hn::Set(di, 1), i7 = hn::Set(di, 7), i8 = hn::Set(di, 8), i10 = hn::Set(di, 10),
             i60 = hn::Set(di, 60);
  for (int y = y0; y <= y1; ++y) {
    const float ii = static_cast<float>(y - win.cy) - win.dy0;
    const auto vi = hn::Set(d, ii);
    const float* mrow = mag.Row(y);
    const float* orow = ori.Row(y);
    int x = x0, x_end = x1;
    if (!detail::RowSpan(win, ii, &x, &x_end)) continue;
    for (; x + n <= x_end + 1; x += n) {
      const auto jj = hn::Iota(d, static_cast<float>(x - win.cx) - win.dx0);
      const auto c_rot = hn::NegMulAdd(vi, sin_t, hn::Mul(jj, cos_t));
      const auto r_rot = hn::MulAdd(vi, cos_t, hn::Mul(jj, sin_t));
      const auto rbin = hn::Add(r_rot, half), cbin = hn::Add(c_rot, half);
      const auto ok = hn::And(hn::And(hn::Gt(rbin, lo), hn::Lt(rbin, hi)),
                              hn::And(hn::Gt(cbin, lo), hn::Lt(cbin, hi)));
      if (hn::AllFalse(d, ok)) continue;
      auto obin = hn::Mul(hn::Sub(hn::LoadU(d, orow + x), ori0), bins);
      obin = hn::IfThenElse(hn::Lt(obin, zero), hn::Add(obin, eight), obin);
      const auto r2 = hn::MulAdd(c_rot, c_rot, hn::Mul(r_rot, r_rot));
      const auto m = hn::Mul(hn::LoadU(d, mrow + x), hn::Exp(d, hn::Mul(r2, escale)));
      const auto r0 = hn::Floor(rbin), c0 = hn::Floor(cbin), o0 = hn::Floor(obin);
      auto oi = hn::ConvertTo(di, o0);
      oi = hn::IfThenElse(hn::Gt(oi, i7), hn::Sub(oi, i8), oi);
      const auto bin = hn::Add(hn::Add(hn::Mul(hn::Add(hn::ConvertTo(di, r0), i1), i60),
                                       hn::Mul(hn::Add(hn::ConvertTo(di, c0), i1), i10)),
                               oi);
      const size_t k = out->n;
      const auto rf = hn::Sub(rbin, r0), cf = hn::Sub(cbin, c0), of = hn::Sub(obin, o0);
#if HWY_TARGET == HWY_AVX3 || HWY_TARGET == HWY_AVX3_DL
      // Native compress in registers, then whole-vector stores (the buffers have a vector of
      // slack): a masked compress-store to memory is microcoded and slow on Zen 4.
      hn::StoreU(hn::Compress(bin, hn::RebindMask(di, ok)), di, out->bin.data() + k);
      hn::StoreU(hn::Compress(rf, ok), d, out->rfrac.data() + k);
      hn::StoreU(hn::Compress(cf, ok), d, out->cfrac.data() + k);
      hn::StoreU(hn::Compress(of, ok), d, out->ofrac.data() + k);
      hn::StoreU(hn::Compress(m, ok), d, out->mag.data() + k);
      out->n += hn::CountTrue(d, ok);
#else
      // Elsewhere (hwy 1.0.3 with GCC copies Compress's lookup table onto the stack per call),
      // store the lanes and append the valid ones.
      HWY_ALIGN int32_t tb[64];
      HWY_ALIGN float tr[64], tc[64], to[64], tm[64];
      uint8_t bits[64 / 8] = {};
      hn::Store(bin, di, tb);
      hn::Store(rf, d, tr);
      hn::Store(cf, d, tc);
      hn::Store(of, d, to);
      hn::Store(m, d, tm);
      hn::StoreMaskBits(d, ok, bits);
      size_t j = k;
      for (int i = 0; i < n; ++i) {
        if (((bits[i / 8] >> (i % 8)) & 1) == 0) continue;
        out->bin[j] = tb[i];
        out->rfrac[j] = tr[i];
        out->cfrac[j] = tc[i];
        out->ofrac[j] = to[i];
        out->mag[j] = tm[i];
        ++j;
      }
      out->n = j;
#endif
    }
    for (; x <= x_end; ++x) {
      detail::DescriptorSample(win, static_cast<float>(x - win.cx) - win.dx0, ii, mrow[x], orow[x],
                               out);
    }
  }
  return HWY_TARGET;
}

}  // namespace mm::sift::HWY_NAMESPACE
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace mm::sift {

HWY_EXPORT(BlurImpl);
HWY_EXPORT(SubtractImpl);
HWY_EXPORT(FindExtremaImpl);
HWY_EXPORT(GradientPolarImpl);
HWY_EXPORT(CollectDescriptorSamplesImpl);

Plane::Plane(int width, int height) { Resize(width, height); }

void Plane::Resize(int width, int height) {
  const size_t n = static_cast<size_t>(width) * static_cast<size_t>(height);
  if (n > capacity || !px) {
    px = hwy::AllocateAligned<float>(std::max<size_t>(n, 1));
    capacity = std::max<size_t>(n, 1);
  }
  w = width;
  h = height;
}

std::vector<float> GaussianHalfKernel(double sigma) {
  const int size = std::max(1, static_cast<int>(std::lround(sigma * 8 + 1)) | 1);
  const int r = size / 2;
  std::vector<double> k(static_cast<size_t>(r + 1));
  double sum = 0;
  for (int i = 0; i <= r; ++i) {
    k[static_cast<size_t>(i)] = std::exp(-0.5 * i * i / (sigma * sigma));
    sum += (i == 0 ? 1 : 2) * k[static_cast<size_t>(i)];
  }
  std::vector<float> out(k.size());
  for (size_t i = 0; i < k.size(); ++i) out[i] = static_cast<float>(k[i] / sum);
  return out;
}

int64_t Blur(const Plane& src, const std::vector<float>& half, Plane* dst, Plane* dog) {
  dst->Resize(src.w, src.h);
  if (dog != nullptr) dog->Resize(src.w, src.h);
  return HWY_DYNAMIC_DISPATCH(BlurImpl)(src, half, dst, dog);
}

void BlurScalar(const Plane& src, const std::vector<float>& half, Plane* dst) {
  dst->Resize(src.w, src.h);
  const int w = src.w, h = src.h, r = static_cast<int>(half.size()) - 1;
  Plane tmp(w, h);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      float acc = half[0] * src.At(y, x);
      for (int i = 1; i <= r; ++i) {
        acc += half[static_cast<size_t>(i)] *
               (src.At(y, detail::Reflect101(x - i, w)) + src.At(y, detail::Reflect101(x + i, w)));
      }
      tmp.Row(y)[x] = acc;
    }
  }
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      float acc = half[0] * tmp.At(y, x);
      for (int i = 1; i <= r; ++i) {
        acc += half[static_cast<size_t>(i)] *
               (tmp.At(detail::Reflect101(y - i, h), x) + tmp.At(detail::Reflect101(y + i, h), x));
      }
      dst->Row(y)[x] = acc;
    }
  }
}

int64_t Subtract(const Plane& a, const Plane& b, Plane* out) {
  out->Resize(a.w, a.h);
  return HWY_DYNAMIC_DISPATCH(SubtractImpl)(a, b, out);
}

int64_t FindExtrema(const Plane& prev, const Plane& cur, const Plane& next, float threshold,
                    int border, std::vector<int>* out) {
  return HWY_DYNAMIC_DISPATCH(FindExtremaImpl)(prev, cur, next, threshold, border, out);
}

void FindExtremaScalar(const Plane& prev, const Plane& cur, const Plane& next, float threshold,
                       int border, std::vector<int>* out) {
  for (int y = border; y < cur.h - border; ++y) {
    for (int x = border; x < cur.w - border; ++x) {
      const float v = cur.At(y, x);
      if (!(std::abs(v) > threshold)) continue;
      bool is_max = v > 0, is_min = v < 0;
      for (const Plane* p : {&prev, &cur, &next}) {
        for (int dy = -1; dy <= 1; ++dy) {
          for (int dx = -1; dx <= 1; ++dx) {
            if (p == &cur && dy == 0 && dx == 0) continue;
            is_max = is_max && v >= p->At(y + dy, x + dx);
            is_min = is_min && v <= p->At(y + dy, x + dx);
          }
        }
      }
      if (is_max || is_min) out->push_back(y * cur.w + x);
    }
  }
}

float FastAtan2Deg(float y, float x) {
  const float ax = std::abs(x), ay = std::abs(y);
  const float t = std::min(ax, ay) / std::max(std::max(ax, ay), 1e-30f);
  const float s = t * t;
  float p = s * detail::kAtan9 + detail::kAtan7;
  p = s * p + detail::kAtan5;
  p = s * p + detail::kAtan3;
  p = s * p + detail::kAtan1;
  float a = t * p * detail::kRadToDeg;
  if (ay > ax) a = 90.0f - a;
  if (x < 0) a = 180.0f - a;
  if (y < 0) a = 360.0f - a;
  return a >= 360.0f ? a - 360.0f : a;
}

int64_t GradientPolar(const Plane& img, Plane* mag, Plane* ori) {
  mag->Resize(img.w, img.h);
  ori->Resize(img.w, img.h);
  return HWY_DYNAMIC_DISPATCH(GradientPolarImpl)(img, mag, ori);
}

void GradientPolarScalar(const Plane& img, Plane* mag, Plane* ori) {
  mag->Resize(img.w, img.h);
  ori->Resize(img.w, img.h);
  for (int y = 0; y < img.h; ++y) {
    for (int x = 0; x < img.w; ++x) {
      float m = 0, o = 0;
      if (y > 0 && y < img.h - 1 && x > 0 && x < img.w - 1) {
        const float dx = img.At(y, x + 1) - img.At(y, x - 1);
        const float dy = img.At(y - 1, x) - img.At(y + 1, x);
        m = std::sqrt(dx * dx + dy * dy);
        o = FastAtan2Deg(dy, dx);
      }
      mag->Row(y)[x] = m;
      ori->Row(y)[x] = o;
    }
  }
}

int64_t CollectDescriptorSamples(const Plane& mag, const Plane& ori, const DescriptorWindow& win,
                                 DescriptorSamples* out) {
  return HWY_DYNAMIC_DISPATCH(CollectDescriptorSamplesImpl)(mag, ori, win, out);
}

void CollectDescriptorSamplesScalar(const Plane& mag, const Plane& ori, const DescriptorWindow& win,
                                    DescriptorSamples* out) {
  detail::ReserveSamples(win, out);
  const int y0 = std::max(1, win.cy - win.radius), y1 = std::min(mag.h - 2, win.cy + win.radius);
  const int x0 = std::max(1, win.cx - win.radius), x1 = std::min(mag.w - 2, win.cx + win.radius);
  for (int y = y0; y <= y1; ++y) {
    for (int x = x0; x <= x1; ++x) {
      detail::DescriptorSample(win, static_cast<float>(x - win.cx) - win.dx0,
                               static_cast<float>(y - win.cy) - win.dy0, mag.At(y, x), ori.At(y, x),
                               out);
    }
  }
}

}  // namespace mm::sift
#endif  // HWY_ONCE
