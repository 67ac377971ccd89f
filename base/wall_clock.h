#pragma once
// Wall-clock companions of the monotonic capture times: the same instant on CLOCK_REALTIME and
// the boot whose CLOCK_MONOTONIC a time is on (report.json, docs/report_schema.md).
//
// Thread-safety: reentrant.

#include <time.h>

#include <cstdint>
#include <fstream>
#include <string>

namespace mm {

inline int64_t ClockNs(clockid_t clock) {
  timespec ts{};
  ::clock_gettime(clock, &ts);
  return static_cast<int64_t>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec;
}

/// A CLOCK_MONOTONIC time in ns on CLOCK_REALTIME, through the clocks' offset now (exact unless
/// the wall clock was stepped since); 0 for 0 (no time).
inline int64_t RealtimeFromMonotonicNs(int64_t monotonic_ns) {
  if (monotonic_ns == 0) return 0;
  const int64_t mono_before = ClockNs(CLOCK_MONOTONIC);
  const int64_t real = ClockNs(CLOCK_REALTIME);
  const int64_t mono_after = ClockNs(CLOCK_MONOTONIC);
  return monotonic_ns + real - (mono_before + (mono_after - mono_before) / 2);
}

/// /proc/sys/kernel/random/boot_id (e.g. "9b1c...-..."), or "" when it cannot be read.
inline std::string BootId() {
  std::ifstream in("/proc/sys/kernel/random/boot_id");
  std::string id;
  std::getline(in, id);
  return id;
}

}  // namespace mm
