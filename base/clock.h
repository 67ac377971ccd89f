#pragma once
// Elapsed time for stage timings (steady clock, seconds).

#include <chrono>

namespace mm {

inline double SecondsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

}  // namespace mm
