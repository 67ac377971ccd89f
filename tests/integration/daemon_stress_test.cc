// 200 trigger cycles in a row, the replay camera as fast as possible: no crash, no leak (RSS
// after the run within 2 % of RSS after the first 50 cycles), every entry complete.
#include <map>

#include "tests/integration/daemon_process.h"

namespace mm::test {
namespace {

long RssKiB(pid_t pid) {
  std::ifstream status("/proc/" + std::to_string(pid) + "/status");
  std::string key;
  while (status >> key) {
    if (key == "VmRSS:") {
      long kib = 0;
      status >> kib;
      return kib;
    }
    status.ignore(1 << 20, '\n');
  }
  return -1;
}

TEST(DaemonStress, TwoHundredTriggerCycles) {
  const int cycles =
      std::getenv("MM_STRESS_CYCLES") ? std::atoi(std::getenv("MM_STRESS_CYCLES")) : 200;
  DaemonProcess daemon("stress", "rate=max&loop=1",
                       "[recon]\nmax_features = 1500\n[log]\nlevel = \"warn\"\n", kData,
                       "max_entries = 20\n");
  daemon.Start();
  int ok = 0, ok_last_100 = 0;
  long rss_after_50 = 0;
  std::map<std::string, int> failures;  // Reason (without its figures) -> count.
  for (int i = 0; i < cycles; ++i) {
    const json result = daemon.TriggerAndWait(60s);
    ASSERT_TRUE(result.is_object()) << "cycle " << i;
    if (result.value("ok", false)) {
      ++ok;
      if (i >= cycles - 100) ++ok_last_100;
    } else {
      const std::string error = result.value("error", "");
      ++failures[error.substr(0, error.find(" ("))];
    }
    if (i == 49) rss_after_50 = RssKiB(daemon.pid());
  }
  const long rss_end = RssKiB(daemon.pid());
  std::cout << "[ figures  ] " << cycles << " cycles, " << ok << " meshes (" << ok_last_100
            << " in the last 100); RSS after 50: " << rss_after_50 << " KiB, after " << cycles
            << ": " << rss_end << " KiB\n";
  for (const auto& [reason, count] : failures) {
    std::cout << "[ figures  ] failed " << count << "x: " << reason << "\n";
  }
  // Pairs that wrap around the 6-frame loop (5 -> 0) break the tracks; the frame that broke
  // them goes to the reconstruction as the last B, which accepts most (500 meshes of 500 on 2
  // busy cores, 200 of 200; 289-420 of 500 when a broken track ended the capture). So: no cycle
  // fails for another reason than a lost track, and the daemon keeps making meshes to the end, not
  // degrade.
  for (const auto& [reason, count] : failures) EXPECT_EQ(reason, "lost track") << count << "x";
  EXPECT_GE(ok, cycles * 8 / 10);
  if (cycles >= 100) {
    EXPECT_GE(ok_last_100, 80);
  }
  // A leak shows as growth over the last 150 cycles: measured 200 888 -> 200 892 KiB (4 KiB).
  // 2 % (4 MB) catches 27 KiB a cycle, less than the 10 % over 450 cycles (45 KiB) it replaces.
  if (cycles >= 100) {
    EXPECT_LE(rss_end, rss_after_50 * 102 / 100);
  }
  const auto entries = VisibleEntries(daemon.spool());
  EXPECT_EQ(entries.size(), std::min<size_t>(20, static_cast<size_t>(ok)));
  for (const fs::path& entry : entries) ExpectCompleteEntry(entry);
  EXPECT_EQ(WEXITSTATUS(daemon.Kill(SIGTERM)), 0);
}

}  // namespace
}  // namespace mm::test
