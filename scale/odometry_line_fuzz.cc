// libFuzzer target for the odometry protocol line (`T X Y Z [QX QY QZ QW]`; the fuzz preset,
// scripts/fuzz.sh). Any input is a sample with finite numbers and a unit quaternion, or nullopt
// with an error that says why.

#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <string>
#include <string_view>

#include "scale/odometry.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string_view line(reinterpret_cast<const char*>(data), size);
  std::string error;
  const std::optional<mm::OdometrySample> sample = mm::ParseOdometryLine(line, &error);
  if (!sample) {
    if (error.empty()) std::abort();
    return 0;
  }
  if (!std::isfinite(sample->time_s) || !sample->position_m.allFinite()) std::abort();
  if (sample->orientation && !(std::abs(sample->orientation->norm() - 1.0) < 1e-9)) std::abort();
  mm::OdometryTrack track(4);
  track.Add(*sample);
  return 0;
}
