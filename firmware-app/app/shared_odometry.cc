#include "app/shared_odometry.h"

#include <chrono>
#include <string>

namespace mm {

void SharedOdometry::Add(const OdometrySample& sample) {
  {
    std::lock_guard lock(mutex_);
    track_.Add(sample);
  }
  arrived_.notify_all();
}

PairScaleInputs SharedOdometry::Lookup(const DaemonConfig& config, const KeyframeInfo& a,
                                       const KeyframeInfo& b) {
  const auto time_of = [&](const KeyframeInfo& k) {
    return config.odometry_clock == DaemonConfig::OdometryClock::kCamera
               ? k.source_time_s
               : static_cast<double>(k.capture_realtime_ns) * 1e-9;
  };
  const double time_a_s = time_of(a), time_b_s = time_of(b);
  const OdometryLookupOptions options{.max_age_s = config.max_odom_age_s};
  const std::chrono::duration<double> wait(config.max_odom_age_s);
  std::unique_lock lock(mutex_);
  arrived_.wait_for(lock, wait,
                    [&] { return !track_.empty() && track_.newest().time_s >= time_b_s; });
  PairScaleInputs out;
  std::string why_a, why_b;
  out.odometry_a_m = track_.PositionAt(time_a_s, options, &why_a);
  out.odometry_b_m = track_.PositionAt(time_b_s, options, &why_b);
  if (!out.odometry_a_m) out.odometry_why_not = "keyframe A: " + why_a;
  if (!out.odometry_b_m) {
    out.odometry_why_not +=
        std::string(out.odometry_why_not.empty() ? "" : "; ") + "keyframe B: " + why_b;
  }
  return out;
}

nlohmann::json SharedOdometry::Describe() {
  std::lock_guard lock(mutex_);
  return {{"samples", track_.size()}, {"newest_s", track_.empty() ? 0.0 : track_.newest().time_s}};
}

}  // namespace mm
