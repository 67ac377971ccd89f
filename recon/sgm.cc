// Semi-global aggregation (recon/sgm.h): one source compiled for every Highway target; the
// vector loop runs over the planes of a pixel, the tail uses the scalar formula.

#include <algorithm>
#include <cstdint>
#include <limits>
#include <span>
#include <vector>

#include "recon/sgm.h"

#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "recon/sgm.cc"
#include <hwy/foreach_target.h>  // IWYU pragma: keep
#include <hwy/highway.h>

#ifndef MM_RECON_SGM_SHARED
#define MM_RECON_SGM_SHARED
namespace mm::sgm_detail {

// Beyond the first and the last plane: never the minimum, and pad + P1 stays in 16 bits.
constexpr uint16_t kPad = 0x3FFF;
constexpr int kPaths[8][2] = {{1, 0}, {-1, 0}, {0, 1}, {0, -1}, {1, 1}, {-1, -1}, {1, -1}, {-1, 1}};

// One plane of the recursion.
inline uint16_t StepOne(uint16_t c, const uint16_t* lp, int d, uint16_t min_p, uint16_t p1,
                        uint16_t jump) {
  const uint16_t near = std::min(lp[d - 1], lp[d + 1]);
  const uint16_t v = std::min(std::min(lp[d], static_cast<uint16_t>(near + p1)), jump);
  return static_cast<uint16_t>(c + v - min_p);
}

// The scalar step over the planes from `d0`: writes L into `l`, adds it to `s`, returns min L.
inline uint16_t StepScalar(const uint16_t* c, const uint16_t* lp, uint16_t min_p, uint16_t p1,
                           uint16_t p2, int d0, int planes, uint16_t* l, uint16_t* s,
                           uint16_t min_l) {
  const uint16_t jump = static_cast<uint16_t>(min_p + p2);
  for (int d = d0; d < planes; ++d) {
    const uint16_t value = StepOne(c[d], lp, d, min_p, p1, jump);
    l[d] = value;
    s[d] = static_cast<uint16_t>(s[d] + value);
    min_l = std::min(min_l, value);
  }
  return min_l;
}

// P2 for the step from q to p along a path.
inline uint16_t AdaptiveP2(const SgmPenalties& pen, const uint8_t* guide, size_t p, size_t q) {
  if (pen.edge_tau <= 0) return pen.p2;
  const int step = std::abs(static_cast<int>(guide[p]) - static_cast<int>(guide[q]));
  const int p2 = pen.p2 * pen.edge_tau / std::max(pen.edge_tau, step);
  return static_cast<uint16_t>(std::max(p2, pen.p1 + 1));
}

// One path over the volume with `step(c, lp, min_p, p2, l, s) -> min L` for pixels with a
// predecessor on the path. Rows of L carry a pad entry either side of the planes.
template <typename Step>
void AggregatePath(const uint16_t* cost, const uint8_t* guide, int width, int height, int planes,
                   const SgmPenalties& pen, int dx, int dy, uint16_t* sum, Step step) {
  const size_t stride = static_cast<size_t>(planes) + 2;
  std::vector<uint16_t> prev_row(static_cast<size_t>(width) * stride, kPad);
  std::vector<uint16_t> cur_row(static_cast<size_t>(width) * stride, kPad);
  std::vector<uint16_t> prev_min(static_cast<size_t>(width), 0);
  std::vector<uint16_t> cur_min(static_cast<size_t>(width), 0);
  const int y0 = dy >= 0 ? 0 : height - 1, y_step = dy >= 0 ? 1 : -1;
  const int x0 = dx >= 0 ? 0 : width - 1, x_step = dx >= 0 ? 1 : -1;
  for (int yi = 0; yi < height; ++yi) {
    const int y = y0 + yi * y_step;
    for (int xi = 0; xi < width; ++xi) {
      const int x = x0 + xi * x_step;
      const size_t p = static_cast<size_t>(y) * width + x;
      const uint16_t* c = cost + p * planes;
      uint16_t* s = sum + p * planes;
      uint16_t* l = &cur_row[static_cast<size_t>(x) * stride + 1];
      const int px = x - dx;  // The predecessor: same row when horizontal, else the row before.
      uint16_t min_l = std::numeric_limits<uint16_t>::max();
      if (px < 0 || px >= width || (dy != 0 && yi == 0)) {
        for (int d = 0; d < planes; ++d) {
          l[d] = c[d];
          s[d] = static_cast<uint16_t>(s[d] + c[d]);
          min_l = std::min(min_l, c[d]);
        }
      } else {
        const std::vector<uint16_t>& src = dy == 0 ? cur_row : prev_row;
        const uint16_t min_p =
            dy == 0 ? cur_min[static_cast<size_t>(px)] : prev_min[static_cast<size_t>(px)];
        const size_t q = static_cast<size_t>(y - dy) * width + px;
        min_l = step(c, &src[static_cast<size_t>(px) * stride + 1], min_p,
                     AdaptiveP2(pen, guide, p, q), l, s);
      }
      cur_min[static_cast<size_t>(x)] = min_l;
    }
    std::swap(prev_row, cur_row);
    std::swap(prev_min, cur_min);
  }
}

inline bool Fits(size_t cost, size_t guide, size_t sum, int width, int height, int planes,
                 const SgmPenalties& pen) {
  if (width < 1 || height < 1 || planes < 1 || pen.p2 > 2048 || pen.p1 >= pen.p2) return false;
  if (pen.edge_tau > 0 && guide != static_cast<size_t>(width) * height) return false;
  const size_t n = static_cast<size_t>(width) * height * planes;
  return cost == n && sum == n;
}

}  // namespace mm::sgm_detail
#endif  // MM_RECON_SGM_SHARED

HWY_BEFORE_NAMESPACE();
namespace mm::HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

// Declared for -Wmissing-declarations; exported below.
int64_t AggregateSgmImpl(const uint16_t* cost, const uint8_t* guide, int width, int height,
                         int planes, const SgmPenalties& pen, uint16_t* sum);

int64_t AggregateSgmImpl(const uint16_t* cost, const uint8_t* guide, int width, int height,
                         int planes, const SgmPenalties& pen, uint16_t* sum) {
  const hn::ScalableTag<uint16_t> du16;
  const int lanes = static_cast<int>(hn::Lanes(du16));
  const uint16_t p1 = pen.p1;
  const auto vp1 = hn::Set(du16, p1);
  auto step = [&](const uint16_t* c, const uint16_t* lp, uint16_t min_p, uint16_t p2, uint16_t* l,
                  uint16_t* s) -> uint16_t {
    const auto vmin_p = hn::Set(du16, min_p);
    const auto jump = hn::Set(du16, static_cast<uint16_t>(min_p + p2));
    auto vmin = hn::Set(du16, std::numeric_limits<uint16_t>::max());
    int d = 0;
    for (; d + lanes <= planes; d += lanes) {
      const auto near = hn::Min(hn::LoadU(du16, lp + d - 1), hn::LoadU(du16, lp + d + 1));
      const auto v = hn::Min(hn::Min(hn::LoadU(du16, lp + d), hn::Add(near, vp1)), jump);
      const auto value = hn::Sub(hn::Add(hn::LoadU(du16, c + d), v), vmin_p);
      hn::StoreU(value, du16, l + d);
      hn::StoreU(hn::Add(hn::LoadU(du16, s + d), value), du16, s + d);
      vmin = hn::Min(vmin, value);
    }
    const uint16_t min_l = hn::GetLane(hn::MinOfLanes(du16, vmin));
    return sgm_detail::StepScalar(c, lp, min_p, p1, p2, d, planes, l, s, min_l);
  };
  for (const auto& path : sgm_detail::kPaths) {
    sgm_detail::AggregatePath(cost, guide, width, height, planes, pen, path[0], path[1], sum, step);
  }
  return HWY_TARGET;
}

}  // namespace mm::HWY_NAMESPACE
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace mm {

HWY_EXPORT(AggregateSgmImpl);

bool AggregateSgm(std::span<const uint16_t> cost, std::span<const uint8_t> guide, int width,
                  int height, int planes, const SgmPenalties& penalties, std::span<uint16_t> sum,
                  int64_t* target_used) {
  if (!sgm_detail::Fits(cost.size(), guide.size(), sum.size(), width, height, planes, penalties)) {
    return false;
  }
  const int64_t target = HWY_DYNAMIC_DISPATCH(AggregateSgmImpl)(
      cost.data(), guide.data(), width, height, planes, penalties, sum.data());
  if (target_used != nullptr) *target_used = target;
  return true;
}

bool AggregateSgmScalar(std::span<const uint16_t> cost, std::span<const uint8_t> guide, int width,
                        int height, int planes, const SgmPenalties& penalties,
                        std::span<uint16_t> sum) {
  if (!sgm_detail::Fits(cost.size(), guide.size(), sum.size(), width, height, planes, penalties)) {
    return false;
  }
  auto step = [&](const uint16_t* c, const uint16_t* lp, uint16_t min_p, uint16_t p2, uint16_t* l,
                  uint16_t* s) {
    return sgm_detail::StepScalar(c, lp, min_p, penalties.p1, p2, 0, planes, l, s,
                                  std::numeric_limits<uint16_t>::max());
  };
  for (const auto& path : sgm_detail::kPaths) {
    sgm_detail::AggregatePath(cost.data(), guide.data(), width, height, planes, penalties, path[0],
                              path[1], sum.data(), step);
  }
  return true;
}

}  // namespace mm
#endif  // HWY_ONCE
