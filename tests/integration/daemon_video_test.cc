// monomeshd on real hand-held video at its recorded rate: the SUN3D study room (50 frames at
// 30 Hz, 1.7 s; data that may not be committed, so the binary skips with 77 without
// ../shared/data) replayed in real time, capture pressed at once and again after each result.
// Every capture that had video to finish on makes an entry; the report lists the B tries.
#include "entry/entry.h"
#include "tests/integration/daemon_process.h"
#include "tests/support/shared_data.h"

namespace mm::test {
namespace {

TEST(DaemonVideo, Sun3dStudyRoomCapturesSucceedAtTheRecordedRate) {
  const fs::path data = RequireSharedData("sun3d_studyroom_continuous");
  DaemonProcess daemon("sun3d", "rate=realtime&loop=0", "[keyframes]\ntimeout_s = 2.0\n", data, "",
                       data / "Calib_Results.m");
  daemon.Start();
  int succeeded = 0;
  int ended_by_video = 0;
  std::vector<fs::path> entries;
  for (int capture = 0; capture < 8; ++capture) {
    if (daemon.Status()["camera"]["end_of_stream"].get<bool>()) break;
    const json result = daemon.TriggerAndWait(30s);
    std::cout << "[ capture  ] " << result.dump() << "\n";
    if (result.value("ok", false)) {
      ++succeeded;
      entries.emplace_back(result["entry"].get<std::string>());
      continue;
    }
    // A capture may only fail because the video ended under it (no frames: no B in time).
    const bool video_ended = daemon.Status()["camera"]["end_of_stream"].get<bool>();
    EXPECT_TRUE(video_ended) << result.dump() << "\n" << daemon.log();
    ++ended_by_video;
  }
  // The first capture starts at once, so it has the whole video: it must make an entry. How many
  // follow depends on the machine: an entry takes ~0.4 s of reconstruction and encoding alone
  // and 1.1 s under a loaded ctest -j2 (measured), which leaves 0-2 more in the 1.7 s.
  EXPECT_GE(succeeded, 1) << daemon.log();
  EXPECT_LE(ended_by_video, 1);
  for (const fs::path& entry : entries) {
    ExpectCompleteEntry(entry);
    EntryReport report;
    ASSERT_EQ(ReadEntryReport(entry, &report), "");
    ASSERT_GE(report.keyframe_b_tries.size(), 1u);
    EXPECT_TRUE(report.keyframe_b_tries.back().accepted);
    // The gate's tracks join the SIFT matches and carry inliers.
    EXPECT_GT(report.counts.gate_track_inliers, 0);
    EXPECT_GT(report.counts.gate_tracks_used, 0);
  }
  EXPECT_EQ(WEXITSTATUS(daemon.Kill(SIGTERM)), 0);
}

}  // namespace
}  // namespace mm::test
