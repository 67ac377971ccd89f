// Brute-force L2 descriptor matching with Google Highway (one source compiled for every SIMD
// target in HWY_TARGETS, chosen at run time by HWY_DYNAMIC_DISPATCH), and its scalar reference.
// Descriptors are rounded to integers in [0, 255] first (OpenCV's SIFT descriptors already are)
// and stored as int16. The SIMD kernel computes |a - b|^2 = |a|^2 + |b|^2 - 2 a.b with integer
// multiply-adds (int16 x int16 -> int32, e.g. _mm256_madd_epi16 / vmlal_s16) against B packed
// so that each lane holds one row's dot product (PackB); the scalar reference sums the squared
// differences in float. Every squared distance is an integer below 128 * 255^2 < 2^24, exact in
// both, so the two paths give bit-identical distances and the same matches whatever the
// summation order.

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <vector>

#include "recon/matcher.h"

#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "recon/matcher.cc"
#include <hwy/aligned_allocator.h>
#include <hwy/foreach_target.h>  // IWYU pragma: keep
#include <hwy/highway.h>

#ifndef MM_RECON_MATCHER_SHARED
#define MM_RECON_MATCHER_SHARED
namespace mm::matcher_detail {

// Running best two of a row of A (squared distances) and the best of a row of B.
struct BestTwo {
  float d1 = std::numeric_limits<float>::infinity();
  float d2 = std::numeric_limits<float>::infinity();
  int j1 = -1;
};
struct BestOne {
  float d = std::numeric_limits<float>::infinity();
  int i = -1;
};

// Rows rounded to integers in [0, 255] as int16, padded to a multiple of 64 lanes (any vector
// width divides it), zero-filled; `norms` holds each row's squared norm. The kernel uses
// unaligned loads.
struct PaddedRows {
  std::vector<int16_t> data;
  std::vector<int32_t> norms;
  size_t rows = 0;
  size_t stride = 0;
};

inline PaddedRows Pad(const cv::Mat& m) {
  PaddedRows out;
  out.rows = static_cast<size_t>(m.rows);
  out.stride = (static_cast<size_t>(m.cols) + 63) / 64 * 64;
  out.data.assign(out.rows * out.stride, 0);
  out.norms.assign(out.rows, 0);
  cv::Mat f;
  m.convertTo(f, CV_32F);
  for (size_t r = 0; r < out.rows; ++r) {
    const float* src = f.ptr<float>(static_cast<int>(r));
    int16_t* dst = out.data.data() + r * out.stride;
    int32_t norm = 0;
    for (int c = 0; c < m.cols; ++c) {
      const auto v = static_cast<int16_t>(std::clamp(std::nearbyint(src[c]), 0.0f, 255.0f));
      dst[c] = v;
      norm += static_cast<int32_t>(v) * v;
    }
    out.norms[r] = norm;
  }
  return out;
}

// Tie rule shared by both paths: a strictly smaller distance wins, so the lowest index is kept.
inline void Update(float d, int i, int j, BestTwo* a, BestOne* b) {
  if (d < a->d1) {
    a->d2 = a->d1;
    a->d1 = d;
    a->j1 = j;
  } else if (d < a->d2) {
    a->d2 = d;
  }
  if (d < b->d) {
    b->d = d;
    b->i = i;
  }
}

}  // namespace mm::matcher_detail
#endif  // MM_RECON_MATCHER_SHARED

HWY_BEFORE_NAMESPACE();
namespace mm::HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

int64_t AllPairsBest(const matcher_detail::PaddedRows& a, const matcher_detail::PaddedRows& b,
                     matcher_detail::BestTwo* best_a, matcher_detail::BestOne* best_b);

#if HWY_TARGET == HWY_SCALAR
// One lane: the dot products one pair at a time.
int64_t AllPairsBest(const matcher_detail::PaddedRows& a, const matcher_detail::PaddedRows& b,
                     matcher_detail::BestTwo* best_a, matcher_detail::BestOne* best_b) {
  for (size_t i = 0; i < a.rows; ++i) {
    for (size_t j = 0; j < b.rows; ++j) {
      int32_t dot = 0;
      for (size_t k = 0; k < a.stride; ++k) {
        dot += int32_t{a.data[i * a.stride + k]} * b.data[j * b.stride + k];
      }
      matcher_detail::Update(static_cast<float>(a.norms[i] + b.norms[j] - 2 * dot),
                             static_cast<int>(i), static_cast<int>(j), best_a + i, best_b + j);
    }
  }
  return HWY_TARGET;
}
#else

// Squared distances are below 128 * 255^2 < 2^23; B's padding rows get a norm that puts them
// above every real distance, and "none yet" is above that.
constexpr int32_t kPaddingNorm = 1 << 28;
constexpr int32_t kNone = std::numeric_limits<int32_t>::max();

// B transposed in blocks of as many rows as a vector has int32 lanes (L): for each pair of
// dimensions (2p, 2p+1), the L rows' two values side by side, so that one int16 multiply-add
// against A's pair broadcast gives the L rows' partial dot products in their own lanes (no
// horizontal sums; the layout of BLAS-like GEMM kernels). Rows past B's end are zero.
template <class D32>
hwy::AlignedFreeUniquePtr<int16_t[]> PackB(D32 d32, const matcher_detail::PaddedRows& b,
                                           size_t blocks,
                                           hwy::AlignedFreeUniquePtr<int32_t[]>* norms) {
  const size_t lanes = hn::Lanes(d32);
  const size_t pairs = b.stride / 2;
  auto packed = hwy::AllocateAligned<int16_t>(blocks * lanes * b.stride);
  *norms = hwy::AllocateAligned<int32_t>(blocks * lanes);
  for (size_t block = 0; block < blocks; ++block) {
    int16_t* out = packed.get() + block * lanes * b.stride;
    for (size_t lane = 0; lane < lanes; ++lane) {
      const size_t row = block * lanes + lane;
      (*norms)[row] = row < b.rows ? b.norms[row] : kPaddingNorm;
      const int16_t* in = row < b.rows ? b.data.data() + row * b.stride : nullptr;
      for (size_t p = 0; p < pairs; ++p) {
        out[(p * lanes + lane) * 2] = in != nullptr ? in[2 * p] : 0;
        out[(p * lanes + lane) * 2 + 1] = in != nullptr ? in[2 * p + 1] : 0;
      }
    }
  }
  return packed;
}

// One row of A's distances to a block of B (in its lanes) into the row's per-lane best two,
// and into B's per-row best (rows of A come in increasing order; strict <: the lowest i wins).
template <class D32, class V>
HWY_INLINE void UpdateBest(D32 d32, V dist, V j, int32_t i, V& d1, V& d2, V& j1, V& best_b_d,
                           V& best_b_i) {
  const auto better = hn::Lt(dist, d1);
  d2 = hn::IfThenElse(better, d1, hn::Min(d2, dist));
  d1 = hn::IfThenElse(better, dist, d1);
  j1 = hn::IfThenElse(better, j, j1);
  const auto better_b = hn::Lt(dist, best_b_d);
  best_b_d = hn::IfThenElse(better_b, dist, best_b_d);
  best_b_i = hn::IfThenElse(better_b, hn::Set(d32, i), best_b_i);
}

// A row's per-lane best twos into its best two: the best is the least d1 (the lowest row on
// ties), the second the least of every d2 and of the d1s but that one.
template <class D32, class V>
HWY_INLINE void MergeLanes(D32 d32, V d1, V d2, V j1, matcher_detail::BestTwo* out) {
  constexpr size_t kMaxLanes = hn::MaxLanes(D32());
  HWY_ALIGN int32_t lane_d1[kMaxLanes], lane_d2[kMaxLanes], lane_j1[kMaxLanes];
  hn::Store(d1, d32, lane_d1);
  hn::Store(d2, d32, lane_d2);
  hn::Store(j1, d32, lane_j1);
  int32_t first = kNone, second = kNone, first_j = -1;
  for (size_t lane = 0; lane < hn::Lanes(d32); ++lane) {
    const int32_t d = lane_d1[lane];
    if (d < first || (d == first && lane_j1[lane] < first_j)) {
      second = first;
      first = d;
      first_j = lane_j1[lane];
    } else {
      second = std::min(second, d);
    }
    second = std::min(second, lane_d2[lane]);
  }
  const auto to_float = [](int32_t d) {
    return d >= kPaddingNorm ? std::numeric_limits<float>::infinity() : static_cast<float>(d);
  };
  out->d1 = to_float(first);
  out->d2 = to_float(second);
  out->j1 = first < kPaddingNorm ? first_j : -1;
}

// Rows i0 .. i0+3 of A against every row of B; rows past A's end are a zero row with a norm
// above every real distance (they change nothing and are not written). Four rows share each
// load of B. (Named variables, not arrays: SVE's vectors cannot be array elements.)
template <class D16, class D32>
HWY_INLINE void FourRowsAgainstB(D16 d16, D32 d32, const matcher_detail::PaddedRows& a, size_t i0,
                                 const int16_t* packed_b, const int32_t* norms_b, size_t blocks,
                                 const int16_t* zero_row, int32_t* best_b_d, int32_t* best_b_i,
                                 matcher_detail::BestTwo* best_a) {
  using V = hn::Vec<D32>;
  const size_t lanes = hn::Lanes(d32);
  const size_t pairs = a.stride / 2;
  const auto row = [&](size_t r) {
    return i0 + r < a.rows ? a.data.data() + (i0 + r) * a.stride : zero_row;
  };
  const auto norm = [&](size_t r) {
    return hn::Set(d32, i0 + r < a.rows ? a.norms[i0 + r] : kPaddingNorm);
  };
  const int16_t *row0 = row(0), *row1 = row(1), *row2 = row(2), *row3 = row(3);
  const V norm0 = norm(0), norm1 = norm(1), norm2 = norm(2), norm3 = norm(3);
  V d1_0 = hn::Set(d32, kNone), d1_1 = d1_0, d1_2 = d1_0, d1_3 = d1_0;
  V d2_0 = d1_0, d2_1 = d1_0, d2_2 = d1_0, d2_3 = d1_0;
  V j1_0 = hn::Set(d32, -1), j1_1 = j1_0, j1_2 = j1_0, j1_3 = j1_0;
  const V iota = hn::Iota(d32, 0);
  const auto broadcast = [&](const int16_t* r, size_t p) {
    int32_t pair;  // A's values at 2p and 2p+1 as one int32.
    std::memcpy(&pair, r + 2 * p, sizeof(pair));
    return hn::BitCast(d16, hn::Set(d32, pair));
  };
  for (size_t block = 0; block < blocks; ++block) {
    const int16_t* pb = packed_b + block * lanes * a.stride;
    V s0 = hn::Zero(d32), s1 = s0, s2 = s0, s3 = s0;  // Lane k: dot with the block's row k.
    V t0 = s0, t1 = s0, t2 = s0, t3 = s0;
    for (size_t p = 0; p < pairs; ++p) {
      const auto vb = hn::Load(d16, pb + p * 2 * lanes);
      s0 = hn::ReorderWidenMulAccumulate(d32, broadcast(row0, p), vb, s0, t0);
      s1 = hn::ReorderWidenMulAccumulate(d32, broadcast(row1, p), vb, s1, t1);
      s2 = hn::ReorderWidenMulAccumulate(d32, broadcast(row2, p), vb, s2, t2);
      s3 = hn::ReorderWidenMulAccumulate(d32, broadcast(row3, p), vb, s3, t3);
    }
    const V norm_b = hn::Load(d32, norms_b + block * lanes);
    const V j = hn::Add(iota, hn::Set(d32, static_cast<int32_t>(block * lanes)));
    V bd = hn::Load(d32, best_b_d + block * lanes);
    V bi = hn::Load(d32, best_b_i + block * lanes);
    const auto dist = [&](V norm_a, V sum0, V sum1) {  // |a|^2 + |b|^2 - 2 a.b
      const V dot = hn::RearrangeToOddPlusEven(sum0, sum1);
      return hn::Sub(hn::Add(norm_a, norm_b), hn::Add(dot, dot));
    };
    const auto i = static_cast<int32_t>(i0);
    UpdateBest(d32, dist(norm0, s0, t0), j, i, d1_0, d2_0, j1_0, bd, bi);
    UpdateBest(d32, dist(norm1, s1, t1), j, i + 1, d1_1, d2_1, j1_1, bd, bi);
    UpdateBest(d32, dist(norm2, s2, t2), j, i + 2, d1_2, d2_2, j1_2, bd, bi);
    UpdateBest(d32, dist(norm3, s3, t3), j, i + 3, d1_3, d2_3, j1_3, bd, bi);
    hn::Store(bd, d32, best_b_d + block * lanes);
    hn::Store(bi, d32, best_b_i + block * lanes);
  }
  MergeLanes(d32, d1_0, d2_0, j1_0, best_a + i0);
  if (i0 + 1 < a.rows) MergeLanes(d32, d1_1, d2_1, j1_1, best_a + i0 + 1);
  if (i0 + 2 < a.rows) MergeLanes(d32, d1_2, d2_2, j1_2, best_a + i0 + 2);
  if (i0 + 3 < a.rows) MergeLanes(d32, d1_3, d2_3, j1_3, best_a + i0 + 3);
}

// All pairs: B packed once (PackB), then A four rows at a time.
int64_t AllPairsBest(const matcher_detail::PaddedRows& a, const matcher_detail::PaddedRows& b,
                     matcher_detail::BestTwo* best_a, matcher_detail::BestOne* best_b) {
  const hn::ScalableTag<int32_t> d32;
  const hn::Repartition<int16_t, decltype(d32)> d16;
  const size_t lanes = hn::Lanes(d32);
  const size_t blocks = (b.rows + lanes - 1) / lanes;
  hwy::AlignedFreeUniquePtr<int32_t[]> norms_b;
  const auto packed_b = PackB(d32, b, blocks, &norms_b);
  auto best_b_d = hwy::AllocateAligned<int32_t>(blocks * lanes);
  auto best_b_i = hwy::AllocateAligned<int32_t>(blocks * lanes);
  std::fill(best_b_d.get(), best_b_d.get() + blocks * lanes, kNone);
  std::fill(best_b_i.get(), best_b_i.get() + blocks * lanes, -1);
  const std::vector<int16_t> zero_row(a.stride, 0);
  for (size_t i = 0; i < a.rows; i += 4) {
    FourRowsAgainstB(d16, d32, a, i, packed_b.get(), norms_b.get(), blocks, zero_row.data(),
                     best_b_d.get(), best_b_i.get(), best_a);
  }
  for (size_t j = 0; j < b.rows; ++j) {
    best_b[j].d =
        best_b_i[j] >= 0 ? static_cast<float>(best_b_d[j]) : std::numeric_limits<float>::infinity();
    best_b[j].i = best_b_i[j];
  }
  return HWY_TARGET;
}
#endif  // HWY_TARGET == HWY_SCALAR

}  // namespace mm::HWY_NAMESPACE
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace mm {
namespace {

HWY_EXPORT(AllPairsBest);

std::vector<Match> Select(const std::vector<matcher_detail::BestTwo>& best_a,
                          const std::vector<matcher_detail::BestOne>& best_b,
                          const MatchOptions& options) {
  std::vector<Match> matches;
  const double r2 = options.ratio * options.ratio;
  for (size_t i = 0; i < best_a.size(); ++i) {
    const matcher_detail::BestTwo& a = best_a[i];
    if (a.j1 < 0 || !std::isfinite(a.d2)) continue;
    if (!(static_cast<double>(a.d1) < r2 * static_cast<double>(a.d2))) continue;
    if (options.mutual && best_b[static_cast<size_t>(a.j1)].i != static_cast<int>(i)) continue;
    matches.push_back({static_cast<int>(i), a.j1, std::sqrt(a.d1)});
  }
  return matches;
}

}  // namespace

std::string MatchOptions::Check() const {
  if (!(ratio > 0 && ratio <= 1)) return "ratio: must be in (0, 1]";
  return {};
}

// Shared by the SIMD matcher and its scalar reference: checks and pads the descriptors, runs
// `all_pairs` to fill the best matches of every row both ways, then applies the ratio test and
// the mutual check.
template <typename AllPairs>
std::vector<Match> MatchPadded(const cv::Mat& descriptors_a, const cv::Mat& descriptors_b,
                               const MatchOptions& options, AllPairs all_pairs) {
  if (descriptors_a.rows < 1 || descriptors_b.rows < 2 ||
      descriptors_a.cols != descriptors_b.cols) {
    return {};
  }
  const matcher_detail::PaddedRows a = matcher_detail::Pad(descriptors_a);
  const matcher_detail::PaddedRows b = matcher_detail::Pad(descriptors_b);
  std::vector<matcher_detail::BestTwo> best_a(a.rows);
  std::vector<matcher_detail::BestOne> best_b(b.rows);
  all_pairs(a, b, best_a, best_b);
  return Select(best_a, best_b, options);
}

std::vector<Match> MatchDescriptors(const cv::Mat& descriptors_a, const cv::Mat& descriptors_b,
                                    const MatchOptions& options, int64_t* target_used) {
  return MatchPadded(descriptors_a, descriptors_b, options,
                     [&](const matcher_detail::PaddedRows& a, const matcher_detail::PaddedRows& b,
                         std::vector<matcher_detail::BestTwo>& best_a,
                         std::vector<matcher_detail::BestOne>& best_b) {
                       const int64_t target =
                           HWY_DYNAMIC_DISPATCH(AllPairsBest)(a, b, best_a.data(), best_b.data());
                       if (target_used != nullptr) *target_used = target;
                     });
}

std::vector<Match> MatchDescriptorsScalar(const cv::Mat& descriptors_a,
                                          const cv::Mat& descriptors_b,
                                          const MatchOptions& options) {
  return MatchPadded(descriptors_a, descriptors_b, options,
                     [](const matcher_detail::PaddedRows& a, const matcher_detail::PaddedRows& b,
                        std::vector<matcher_detail::BestTwo>& best_a,
                        std::vector<matcher_detail::BestOne>& best_b) {
                       for (size_t i = 0; i < a.rows; ++i) {
                         for (size_t j = 0; j < b.rows; ++j) {
                           float s = 0;
                           for (size_t k = 0; k < a.stride; ++k) {
                             const float e = static_cast<float>(a.data[i * a.stride + k]) -
                                             static_cast<float>(b.data[j * b.stride + k]);
                             s += e * e;
                           }
                           matcher_detail::Update(s, static_cast<int>(i), static_cast<int>(j),
                                                  &best_a[i], &best_b[j]);
                         }
                       }
                     });
}

}  // namespace mm
#endif  // HWY_ONCE
