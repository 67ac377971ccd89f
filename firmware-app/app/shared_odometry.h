#pragma once
// The robot's odometry (`odom` lines on the control socket): the event loop adds samples, the
// worker looks up the keyframes' positions once the stream has reached keyframe B's time.
//
// Thread-safety: every method from any thread (one mutex).

#include <condition_variable>
#include <mutex>
#include <nlohmann/json.hpp>

#include "app/config.h"
#include "app/pair_job.h"
#include "entry/report.h"
#include "scale/odometry.h"

namespace mm {

class SharedOdometry {
 public:
  void Add(const OdometrySample& sample);

  /// The positions at keyframes `a` and `b`'s times on the clock of the `odom` timestamps
  /// ([scale] odometry_clock), after waiting up to max_odom_age_s for a sample at or after
  /// b's time (a bridge's latency); what is missing comes with its reason.
  PairScaleInputs Lookup(const DaemonConfig& config, const KeyframeInfo& a, const KeyframeInfo& b);

  nlohmann::json Describe();

 private:
  std::mutex mutex_;
  std::condition_variable arrived_;
  OdometryTrack track_;  // Guarded by mutex_.
};

}  // namespace mm
