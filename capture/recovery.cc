#include "capture/recovery.h"

#include <algorithm>
#include <thread>

namespace mm {

void DeviceRecovery::Reset() {
  lost_ = false;
  backoff_ms_ = options_.reopen_min_ms;
  last_frame_ = Clock::now();
}

bool DeviceRecovery::Silent() const {
  return Clock::now() - last_frame_ > std::chrono::milliseconds(options_.lost_after_ms);
}

void DeviceRecovery::Lose() {
  lost_ = true;
  ++losses_;
  backoff_ms_ = options_.reopen_min_ms;
  next_attempt_ = Clock::now() + std::chrono::milliseconds(backoff_ms_);
}

bool DeviceRecovery::AttemptDue(Clock::time_point deadline) {
  if (Clock::now() >= next_attempt_) return true;
  std::this_thread::sleep_until(std::min(deadline, next_attempt_));
  return false;
}

void DeviceRecovery::AttemptFailed() {
  backoff_ms_ = std::min(backoff_ms_ * 2, options_.reopen_max_ms);
  next_attempt_ = Clock::now() + std::chrono::milliseconds(backoff_ms_);
}

void DeviceRecovery::AttemptSucceeded() {
  lost_ = false;
  ++reopens_;
  last_frame_ = Clock::now();
}

}  // namespace mm
