#pragma once
// Semi-global matching aggregation (Hirschmueller, "Stereo Processing by Semiglobal Matching
// and Mutual Information", PAMI 2008, Sec. 3.3) of a cost volume over eight image paths, for
// the plane sweep of recon/dense.h. Along each path r:
//   L_r(p, d) = C(p, d) + min(L_r(p-r, d), L_r(p-r, d+-1) + P1, min_k L_r(p-r, k) + P2)
//               - min_k L_r(p-r, k),
// summed over the paths. With a guide image P2 adapts to the intensity step along the path,
// P2 = max(P1 + 1, P2' * tau / max(tau, |I(p) - I(p-r)|)) (Hirschmueller 2008, Sec. 3.3:
// depth jumps are cheaper where the image has an edge, against foreground fattening). The inner
// loop over the planes runs with Google Highway on every target in HWY_TARGETS (chosen at run time,
// as recon/matcher.cc), beside its scalar reference; both give the same sums.
//
// Thread-safety: pure functions; reentrant.

#include <cstdint>
#include <span>

namespace mm {

/// `cost` and `sum` are pixel-major: index (y * width + x) * planes + d. Costs must stay
/// <= 2048 and P2 <= 2048 so that eight paths sum within 16 bits. Returns false (and leaves
/// `sum`) when the sizes do not fit. `target_used`: the Highway target that ran.
struct SgmPenalties {
  uint16_t p1 = 5;
  uint16_t p2 = 38;
  /// Intensity step (grey levels) from which P2 shrinks; 0 = constant P2.
  int edge_tau = 0;
};

/// `guide`: width x height 8-bit grey image, row-major (empty when edge_tau is 0).
bool AggregateSgm(std::span<const uint16_t> cost, std::span<const uint8_t> guide, int width,
                  int height, int planes, const SgmPenalties& penalties, std::span<uint16_t> sum,
                  int64_t* target_used = nullptr);

/// The scalar reference.
bool AggregateSgmScalar(std::span<const uint16_t> cost, std::span<const uint8_t> guide, int width,
                        int height, int planes, const SgmPenalties& penalties,
                        std::span<uint16_t> sum);

}  // namespace mm
