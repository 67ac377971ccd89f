#include "capture/frame_rate.h"

#include <algorithm>

namespace mm {

void FrameRateMeter::Add(Clock::time_point arrival) {
  arrivals_[next_] = arrival;
  next_ = (next_ + 1) % kWindow;
  count_ = std::min(count_ + 1, kWindow);
}

double FrameRateMeter::RateHz(Clock::time_point now) const {
  if (count_ < 2) return 0.0;
  const Clock::time_point newest = arrivals_[(next_ + kWindow - 1) % kWindow];
  const Clock::time_point oldest = arrivals_[count_ < kWindow ? 0 : next_];
  const std::chrono::duration<double> span = newest - oldest;
  if (!(span.count() > 0)) return 0.0;
  const double intervals = static_cast<double>(count_ - 1);
  const std::chrono::duration<double> silent = now - newest;
  if (silent.count() > std::max(1.0, 3.0 * span.count() / intervals)) return 0.0;
  return intervals / span.count();
}

}  // namespace mm
