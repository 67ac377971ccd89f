// Trigger sources without hardware: debounce logic, option checks and the errors for a
// missing GPIO chip; SIGUSR1 through the signalfd adapter. (gpio-sim edges: tests/kernel.)

#include "capture/trigger.h"

#include <gtest/gtest.h>
#include <poll.h>
#include <signal.h>

namespace mm {
namespace {

constexpr int64_t kMs = 1000000;

TEST(Debouncer, BurstGivesOnePressAndOneRelease) {
  Debouncer d(30 * kMs);
  int reported = 0;
  // Press with 5 bounces 1 ms apart, then hold, then release with bounces.
  bool level = true;
  for (int i = 0; i < 6; ++i, level = !level) reported += d.Edge(1000 * kMs + i * kMs, level);
  EXPECT_EQ(reported, 1);
  EXPECT_TRUE(d.level());
  reported = 0;
  level = false;
  for (int i = 0; i < 5; ++i, level = !level) reported += d.Edge(2000 * kMs + i * kMs, level);
  EXPECT_EQ(reported, 1);
  EXPECT_FALSE(d.level());
}

TEST(Debouncer, ZeroDebounceReportsEveryChange) {
  Debouncer d(0);
  EXPECT_TRUE(d.Edge(1, true));
  EXPECT_FALSE(d.Edge(2, true));  // No change of level.
  EXPECT_TRUE(d.Edge(3, false));
}

TEST(GpioButton, MissingChipIsNamed) {
  GpioButtonOptions o;
  o.chip = "no-such-chip";
  GpioButton b(o);
  const std::string e = b.Open();
  EXPECT_NE(e.find("gpio: chip 'no-such-chip'"), std::string::npos) << e;
}

TEST(GpioButton, OptionsAreChecked) {
  GpioButtonOptions o;
  EXPECT_EQ(o.Check(), "");
  o.bias = "sideways";
  EXPECT_NE(o.Check().find("bias 'sideways'"), std::string::npos);
}

TEST(SignalTrigger, Sigusr1BecomesAPress) {
  SignalTrigger t(SIGUSR1);
  ASSERT_EQ(t.Open(), "");
  ASSERT_EQ(::raise(SIGUSR1), 0);
  pollfd p{t.fd(), POLLIN, 0};
  ASSERT_EQ(::poll(&p, 1, 1000), 1);
  TriggerEvent ev;
  std::string error;
  ASSERT_EQ(t.ReadEvent(&ev, &error), 1) << error;
  EXPECT_EQ(ev.source, "SIGUSR1");
  EXPECT_TRUE(ev.pressed);
  EXPECT_EQ(t.ReadEvent(&ev, &error), 0);
}

}  // namespace
}  // namespace mm
