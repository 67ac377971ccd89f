// 300 trigger cycles in a row, the bundled 1 Hz keyframes replayed in a loop at a camera's
// 30 Hz (each frame a large step, so a B is one or two frames after its A): no crash, no leak
// (the daemon's RSS floor over the last 50 cycles within 3 % of its floor over cycles 51-100),
// every entry complete. (At rate=max the replay's PNG decoding was half the test's CPU.)
#include <algorithm>
#include <limits>
#include <map>
#include <vector>

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

TEST(DaemonStress, ThreeHundredTriggerCycles) {
  const int cycles =
      std::getenv("MM_STRESS_CYCLES") ? std::atoi(std::getenv("MM_STRESS_CYCLES")) : 300;
  DaemonProcess daemon("stress", "rate=realtime&speed=30&loop=1",
                       "[recon]\nmax_features = 1500\n[log]\nlevel = \"warn\"\n", kData,
                       "max_entries = 20\n");
  daemon.Start();
  int ok = 0, ok_last_100 = 0;
  // RSS every 5 cycles. A sample taken while a capture is in flight holds its working set (5 %
  // above the floor with three accuracy tests beside it), and in a suite run the RSS stepped
  // once from 200 to 239 MB at cycle 30 and stayed there (+-1 MB to cycle 200): so the leak
  // check compares floors, the least RSS of cycles 51-100 against that of the last 50.
  std::vector<long> rss_kib;
  std::string rss_trace;
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
    if ((i + 1) % 5 == 0) {
      rss_kib.push_back(RssKiB(daemon.pid()));
      rss_trace += " " + std::to_string(rss_kib.back());
    }
  }
  const auto floor_of = [&](int first_cycle, int last_cycle) {  // 1-based, inclusive
    long floor = std::numeric_limits<long>::max();
    for (size_t j = 0; j < rss_kib.size(); ++j) {
      const int cycle = static_cast<int>(j + 1) * 5;
      if (cycle >= first_cycle && cycle <= last_cycle) floor = std::min(floor, rss_kib[j]);
    }
    return floor;
  };
  const long floor_early = floor_of(51, 100);
  const long floor_late = floor_of(cycles - 49, cycles);
  std::cout << "[ figures  ] " << cycles << " cycles, " << ok << " meshes (" << ok_last_100
            << " in the last 100); RSS floor over cycles 51-100: " << floor_early
            << " KiB, over the last 50: " << floor_late << " KiB; every 5 cycles:" << rss_trace
            << "\n";
  for (const auto& [reason, count] : failures) {
    std::cout << "[ figures  ] failed " << count << "x: " << reason << "\n";
  }
  // Pairs that wrap around the 6-frame loop (5 -> 0) break the tracks; the frame that broke
  // them goes to the reconstruction as the last B, which accepts most (500 meshes of 500 on 2
  // busy cores, 200 of 200 in 6 runs; 289-420 of 500 when a broken track ended the capture). So: no
  // cycle fails for another reason than a lost track, and the daemon keeps making meshes to the
  // end, not degrade.
  for (const auto& [reason, count] : failures) EXPECT_EQ(reason, "lost track") << count << "x";
  EXPECT_GE(ok, cycles * 8 / 10);
  if (cycles >= 100) {
    EXPECT_GE(ok_last_100, 80);
  }
  // A leak raises the floor. Measured over 200 cycles: +1.1 % with three accuracy tests beside
  // it, -0.3 % in a suite run. 3 % (6-7 MB) over the 200 cycles between the windows catches
  // about 35 KiB a cycle, as the 10 % of a point sample over 450 cycles did.
  if (cycles >= 200) {
    EXPECT_LE(floor_late, floor_early * 103 / 100);
  }
  const auto entries = VisibleEntries(daemon.spool());
  EXPECT_EQ(entries.size(), std::min<size_t>(20, static_cast<size_t>(ok)));
  for (const fs::path& entry : entries) ExpectCompleteEntry(entry);
  EXPECT_EQ(WEXITSTATUS(daemon.Kill(SIGTERM)), 0);
}

}  // namespace
}  // namespace mm::test
