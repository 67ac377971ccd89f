// The loss/reopen bookkeeping of the device sources, without a device (the real losses and
// recoveries run against vivid and v4l2loopback in tests/kernel). Delays are long enough that
// scheduling stalls of a loaded machine do not change the outcome; the lower bounds on the
// measured waits hold by construction.

#include "capture/recovery.h"

#include <gtest/gtest.h>

#include <thread>

namespace mm {
namespace {

using Clock = DeviceRecovery::Clock;
using std::chrono::milliseconds;

TEST(DeviceRecovery, SilenceAfterLostAfterMs) {
  DeviceRecovery r({.lost_after_ms = 300, .reopen_min_ms = 50, .reopen_max_ms = 200});
  r.Reset();
  EXPECT_FALSE(r.Silent());
  std::this_thread::sleep_for(milliseconds(350));
  EXPECT_TRUE(r.Silent());
  r.FrameArrived();
  EXPECT_FALSE(r.Silent());
}

TEST(DeviceRecovery, BackoffDoublesToTheCeilingAndResetsOnLoss) {
  DeviceRecovery r({.lost_after_ms = 1000, .reopen_min_ms = 50, .reopen_max_ms = 200});
  r.Reset();
  const auto lost_at = Clock::now();
  r.Lose();
  EXPECT_TRUE(r.lost());
  EXPECT_EQ(r.losses(), 1u);
  EXPECT_EQ(r.backoff_ms(), 50);
  // Not due yet: sleeps until the (earlier) deadline and says no.
  EXPECT_FALSE(r.AttemptDue(Clock::now() + milliseconds(1)));
  // Due only once the back-off has passed (each call sleeps towards it).
  while (!r.AttemptDue(Clock::now() + milliseconds(500))) {
  }
  EXPECT_GE(Clock::now() - lost_at, milliseconds(50));
  r.AttemptFailed();
  EXPECT_EQ(r.backoff_ms(), 100);
  r.AttemptFailed();
  const auto failed_at = Clock::now();
  r.AttemptFailed();
  EXPECT_EQ(r.backoff_ms(), 200);  // Capped.
  while (!r.AttemptDue(Clock::now() + milliseconds(500))) {
  }
  EXPECT_GE(Clock::now() - failed_at, milliseconds(200));
  r.AttemptSucceeded();
  EXPECT_FALSE(r.lost());
  EXPECT_EQ(r.reopens(), 1u);
  EXPECT_FALSE(r.Silent());
  r.Lose();
  EXPECT_EQ(r.backoff_ms(), 50);  // A new loss starts from the shortest delay again.
  EXPECT_EQ(r.losses(), 2u);
}

}  // namespace
}  // namespace mm
