// Brute-force L2 descriptor matching with Google Highway (one source compiled for every SIMD
// target in HWY_TARGETS, chosen at run time by HWY_DYNAMIC_DISPATCH), and its scalar reference.
// Descriptors are rounded to integers in [0, 255] first (OpenCV's SIFT descriptors already are),
// so every squared distance is an integer below 2^24 and exact in float whatever the summation
// order: the SIMD and scalar paths then give bit-identical distances and the same matches.

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <vector>

#include "recon/features.h"

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

// Rows padded to a multiple of 64 floats (any vector width divides it), zero-filled; the
// kernel uses unaligned loads.
struct PaddedRows {
  std::vector<float> data;
  size_t rows = 0;
  size_t stride = 0;
};

inline PaddedRows Pad(const cv::Mat& m) {
  PaddedRows out;
  out.rows = static_cast<size_t>(m.rows);
  out.stride = (static_cast<size_t>(m.cols) + 63) / 64 * 64;
  out.data.assign(out.rows * out.stride, 0.0f);
  cv::Mat f;
  m.convertTo(f, CV_32F);
  for (size_t r = 0; r < out.rows; ++r) {
    const float* src = f.ptr<float>(static_cast<int>(r));
    float* dst = out.data.data() + r * out.stride;
    for (int c = 0; c < m.cols; ++c) dst[c] = std::clamp(std::nearbyint(src[c]), 0.0f, 255.0f);
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

int64_t AllPairsBest(const float* a, size_t na, const float* b, size_t nb, size_t stride,
                     matcher_detail::BestTwo* best_a, matcher_detail::BestOne* best_b);

// All-pairs squared distances in tiles of 4 rows of A against one row of B; rows of A are
// visited in increasing order for every B, so the tie rule matches the scalar loop.
int64_t AllPairsBest(const float* a, size_t na, const float* b, size_t nb, size_t stride,
                     matcher_detail::BestTwo* best_a, matcher_detail::BestOne* best_b) {
  const hn::ScalableTag<float> d;
  const size_t lanes = hn::Lanes(d);
  size_t i = 0;
  for (; i + 4 <= na; i += 4) {
    const float* a0 = a + i * stride;
    const float* a1 = a0 + stride;
    const float* a2 = a1 + stride;
    const float* a3 = a2 + stride;
    for (size_t j = 0; j < nb; ++j) {
      const float* bj = b + j * stride;
      auto s0 = hn::Zero(d), s1 = hn::Zero(d), s2 = hn::Zero(d), s3 = hn::Zero(d);
      for (size_t k = 0; k < stride; k += lanes) {
        const auto vb = hn::LoadU(d, bj + k);
        const auto e0 = hn::Sub(hn::LoadU(d, a0 + k), vb);
        const auto e1 = hn::Sub(hn::LoadU(d, a1 + k), vb);
        const auto e2 = hn::Sub(hn::LoadU(d, a2 + k), vb);
        const auto e3 = hn::Sub(hn::LoadU(d, a3 + k), vb);
        s0 = hn::MulAdd(e0, e0, s0);
        s1 = hn::MulAdd(e1, e1, s1);
        s2 = hn::MulAdd(e2, e2, s2);
        s3 = hn::MulAdd(e3, e3, s3);
      }
      const int jj = static_cast<int>(j);
      matcher_detail::BestOne* bb = best_b + j;
      matcher_detail::Update(hn::GetLane(hn::SumOfLanes(d, s0)), static_cast<int>(i), jj,
                             best_a + i, bb);
      matcher_detail::Update(hn::GetLane(hn::SumOfLanes(d, s1)), static_cast<int>(i + 1), jj,
                             best_a + i + 1, bb);
      matcher_detail::Update(hn::GetLane(hn::SumOfLanes(d, s2)), static_cast<int>(i + 2), jj,
                             best_a + i + 2, bb);
      matcher_detail::Update(hn::GetLane(hn::SumOfLanes(d, s3)), static_cast<int>(i + 3), jj,
                             best_a + i + 3, bb);
    }
  }
  for (; i < na; ++i) {
    const float* ai = a + i * stride;
    for (size_t j = 0; j < nb; ++j) {
      const float* bj = b + j * stride;
      auto s = hn::Zero(d);
      for (size_t k = 0; k < stride; k += lanes) {
        const auto e = hn::Sub(hn::LoadU(d, ai + k), hn::LoadU(d, bj + k));
        s = hn::MulAdd(e, e, s);
      }
      matcher_detail::Update(hn::GetLane(hn::SumOfLanes(d, s)), static_cast<int>(i),
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
        const int64_t target = HWY_DYNAMIC_DISPATCH(AllPairsBest)(
            a.data.data(), a.rows, b.data.data(), b.rows, a.stride, best_a.data(),
            best_b.data());
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
              const float e = a.data[i * a.stride + k] - b.data[j * b.stride + k];
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
