// Brute-force L2 descriptor matching with Google Highway (one source compiled for every SIMD
// target in HWY_TARGETS, chosen at run time by HWY_DYNAMIC_DISPATCH), and its scalar reference.
// Descriptors are rounded to integers in [0, 255] first (OpenCV's SIFT descriptors already are)
// and stored as int16. The SIMD kernel computes |a - b|^2 = |a|^2 + |b|^2 - 2 a.b with integer
// multiply-adds (int16 x int16 -> int32, e.g. _mm256_madd_epi16 / vmlal_s16); the scalar
// reference sums the squared differences in float. Every squared distance is an integer below
// 128 * 255^2 < 2^24, exact in both, so the two paths give bit-identical distances and the
// same matches whatever the summation order.

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <vector>

#include "recon/matcher.h"

#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "recon/matcher.cc"
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

// Dot product of one int16 row with int32 accumulation (two accumulators: the pairwise
// multiply-add may split the products between them on some targets).
template <class D16, class D32>
HWY_INLINE int32_t Dot(D16 d16, D32 d32, const int16_t* x, const int16_t* y, size_t stride) {
  auto s0 = hn::Zero(d32), s1 = hn::Zero(d32);
  for (size_t k = 0; k < stride; k += hn::Lanes(d16)) {
    s0 = hn::ReorderWidenMulAccumulate(d32, hn::LoadU(d16, x + k), hn::LoadU(d16, y + k), s0,
                                       s1);
  }
  return hn::GetLane(hn::SumOfLanes(d32, hn::Add(s0, s1)));
}

// Squared distance from the norms and the dot product: exact integers, below 2^24.
HWY_INLINE float Distance(int32_t norm_a, int32_t norm_b, int32_t dot) {
  return static_cast<float>(norm_a + norm_b - 2 * dot);
}

// All-pairs dot products in tiles of 4 rows of A against one row of B; rows of A are visited
// in increasing order for every B, so the tie rule matches the scalar loop.
int64_t AllPairsBest(const matcher_detail::PaddedRows& a, const matcher_detail::PaddedRows& b,
                     matcher_detail::BestTwo* best_a, matcher_detail::BestOne* best_b) {
  const hn::ScalableTag<int16_t> d16;
  const hn::Repartition<int32_t, decltype(d16)> d32;
  const size_t lanes = hn::Lanes(d16);
  const size_t stride = a.stride;
  const size_t na = a.rows, nb = b.rows;
  size_t i = 0;
  for (; i + 4 <= na; i += 4) {
    const int16_t* a0 = a.data.data() + i * stride;
    const int16_t* a1 = a0 + stride;
    const int16_t* a2 = a1 + stride;
    const int16_t* a3 = a2 + stride;
    const int32_t n0 = a.norms[i], n1 = a.norms[i + 1], n2 = a.norms[i + 2],
                  n3 = a.norms[i + 3];
    for (size_t j = 0; j < nb; ++j) {
      const int16_t* bj = b.data.data() + j * stride;
      auto s0 = hn::Zero(d32), s1 = hn::Zero(d32), s2 = hn::Zero(d32), s3 = hn::Zero(d32);
      auto t0 = hn::Zero(d32), t1 = hn::Zero(d32), t2 = hn::Zero(d32), t3 = hn::Zero(d32);
      for (size_t k = 0; k < stride; k += lanes) {
        const auto vb = hn::LoadU(d16, bj + k);
        s0 = hn::ReorderWidenMulAccumulate(d32, hn::LoadU(d16, a0 + k), vb, s0, t0);
        s1 = hn::ReorderWidenMulAccumulate(d32, hn::LoadU(d16, a1 + k), vb, s1, t1);
        s2 = hn::ReorderWidenMulAccumulate(d32, hn::LoadU(d16, a2 + k), vb, s2, t2);
        s3 = hn::ReorderWidenMulAccumulate(d32, hn::LoadU(d16, a3 + k), vb, s3, t3);
      }
      const int32_t nbj = b.norms[j];
      const int jj = static_cast<int>(j);
      matcher_detail::BestOne* bb = best_b + j;
      matcher_detail::Update(Distance(n0, nbj, hn::GetLane(hn::SumOfLanes(d32, hn::Add(s0, t0)))),
                             static_cast<int>(i), jj, best_a + i, bb);
      matcher_detail::Update(Distance(n1, nbj, hn::GetLane(hn::SumOfLanes(d32, hn::Add(s1, t1)))),
                             static_cast<int>(i + 1), jj, best_a + i + 1, bb);
      matcher_detail::Update(Distance(n2, nbj, hn::GetLane(hn::SumOfLanes(d32, hn::Add(s2, t2)))),
                             static_cast<int>(i + 2), jj, best_a + i + 2, bb);
      matcher_detail::Update(Distance(n3, nbj, hn::GetLane(hn::SumOfLanes(d32, hn::Add(s3, t3)))),
                             static_cast<int>(i + 3), jj, best_a + i + 3, bb);
    }
  }
  for (; i < na; ++i) {
    const int16_t* ai = a.data.data() + i * stride;
    for (size_t j = 0; j < nb; ++j) {
      const int32_t dot = Dot(d16, d32, ai, b.data.data() + j * stride, stride);
      matcher_detail::Update(Distance(a.norms[i], b.norms[j], dot), static_cast<int>(i),
                             static_cast<int>(j), best_a + i, best_b + j);
    }
  }
  return HWY_TARGET;
}

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
  return MatchPadded(
      descriptors_a, descriptors_b, options,
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
  return MatchPadded(
      descriptors_a, descriptors_b, options,
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
            matcher_detail::Update(s, static_cast<int>(i), static_cast<int>(j), &best_a[i],
                                   &best_b[j]);
          }
        }
      });
}

}  // namespace mm
#endif  // HWY_ONCE
