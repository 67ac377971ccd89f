#include "capture/frame_rate.h"

#include <gtest/gtest.h>

namespace mm {
namespace {

using namespace std::chrono_literals;
using Clock = FrameRateMeter::Clock;

TEST(FrameRateMeter, NoRateBeforeTwoFrames) {
  FrameRateMeter meter;
  const Clock::time_point t0{};
  EXPECT_EQ(meter.RateHz(t0), 0.0);
  meter.Add(t0);
  EXPECT_EQ(meter.RateHz(t0), 0.0);
  meter.Add(t0 + 40ms);
  EXPECT_NEAR(meter.RateHz(t0 + 40ms), 25.0, 1e-9);
}

TEST(FrameRateMeter, FollowsTheNewestWindowOfArrivals) {
  FrameRateMeter meter;
  Clock::time_point t{};
  // 100 frames at 30 Hz, then the camera slows to 10 Hz: once the window holds only the new
  // arrivals, the rate is theirs.
  for (int i = 0; i < 100; ++i, t += std::chrono::microseconds(33333)) meter.Add(t);
  EXPECT_NEAR(meter.RateHz(t), 30.0, 0.01);
  for (size_t i = 0; i < FrameRateMeter::kWindow; ++i, t += 100ms) meter.Add(t);
  EXPECT_NEAR(meter.RateHz(t - 100ms), 10.0, 1e-6);
}

TEST(FrameRateMeter, AStalledCameraHasNoRate) {
  FrameRateMeter meter;
  Clock::time_point t{};
  for (int i = 0; i < 10; ++i, t += 50ms) meter.Add(t);
  const Clock::time_point newest = t - 50ms;
  EXPECT_NEAR(meter.RateHz(newest + 900ms), 20.0, 1e-6);  // Within 1 s: still 20 Hz.
  EXPECT_EQ(meter.RateHz(newest + 1100ms), 0.0);
  // A slow camera (one frame every 2 s) keeps its rate for three intervals.
  FrameRateMeter slow;
  for (int i = 0; i < 3; ++i) slow.Add(Clock::time_point{} + i * 2s);
  EXPECT_NEAR(slow.RateHz(Clock::time_point{} + 9s), 0.5, 1e-9);
  EXPECT_EQ(slow.RateHz(Clock::time_point{} + 11s), 0.0);
}

}  // namespace
}  // namespace mm
