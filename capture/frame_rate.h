#pragma once
// The rate a camera delivers frames at, measured from their arrival times over a sliding
// window of the newest arrivals (what an operator wants to see: the camera's rate as the
// daemon receives it, drops by the driver included).
//
// Thread-safety: none (CaptureThread guards it with its mutex).

#include <array>
#include <chrono>
#include <cstddef>

namespace mm {

class FrameRateMeter {
 public:
  using Clock = std::chrono::steady_clock;
  static constexpr size_t kWindow = 32;

  void Add(Clock::time_point arrival);

  /// Frames per second over the window: (n - 1) / (newest - oldest) for its n arrivals.
  /// 0 with fewer than two arrivals, and once the camera is silent at `now` for longer than
  /// max(1 s, three of the window's mean intervals): a stalled camera has no rate.
  [[nodiscard]] double RateHz(Clock::time_point now) const;

 private:
  std::array<Clock::time_point, kWindow> arrivals_{};  // A ring; next_ is the oldest when full.
  size_t count_ = 0;
  size_t next_ = 0;
};

}  // namespace mm
