#pragma once
// Elapsed time for stage timings (steady clock, seconds) and CPU time (seconds).

#include <time.h>

#include <chrono>

namespace mm {

inline double SecondsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

namespace clock_detail {
inline double Seconds(clockid_t clock) {
  timespec ts{};
  clock_gettime(clock, &ts);
  return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}
}  // namespace clock_detail

/// CPU time of the calling thread.
inline double ThreadCpuSeconds() { return clock_detail::Seconds(CLOCK_THREAD_CPUTIME_ID); }
/// CPU time of the process (all its threads).
inline double ProcessCpuSeconds() { return clock_detail::Seconds(CLOCK_PROCESS_CPUTIME_ID); }

}  // namespace mm
