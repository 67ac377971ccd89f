#pragma once
// Order statistics of a sample, one definition each for every layer: MedianOf (the element at
// n / 2 after sorting, the upper median), QuantileOf (the element at floor(q (n - 1)), so
// QuantileOf(v, 0.5) is the lower median) and Percentile (linear interpolation between order
// statistics, numpy's default). Each takes a copy, and returns 0 for an empty sample.
//
// Thread-safety: pure functions; reentrant.

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <vector>

namespace mm {

/// The element at n / 2 of the sorted sample (upper median).
inline double MedianOf(std::vector<double> v) {
  if (v.empty()) return 0.0;
  const auto mid = v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2);
  std::nth_element(v.begin(), mid, v.end());
  return *mid;
}

/// The element at floor(q (n - 1)) of the sorted sample, q in [0, 1].
inline double QuantileOf(std::vector<double> v, double q) {
  if (v.empty()) return 0.0;
  const auto k = static_cast<size_t>(q * static_cast<double>(v.size() - 1));
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(k), v.end());
  return v[k];
}

/// Percentile with linear interpolation between order statistics (numpy's default).
inline double Percentile(std::vector<double> values, double percent) {
  if (values.empty()) return 0.0;
  std::sort(values.begin(), values.end());
  const double pos =
      std::clamp(percent, 0.0, 100.0) / 100.0 * static_cast<double>(values.size() - 1);
  const auto lo = static_cast<size_t>(std::floor(pos));
  const size_t hi = std::min(lo + 1, values.size() - 1);
  return values[lo] + (pos - static_cast<double>(lo)) * (values[hi] - values[lo]);
}

}  // namespace mm
