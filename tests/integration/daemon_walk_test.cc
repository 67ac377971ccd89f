// monomeshd in walk mode (docs/walk.md): the synthetic L-shaped corridor replayed in real time,
// `ctl walk start`, one walk entry in metres (floor scale) when the camera ends, checked against
// the exact ground truth by `monomesh eval --spool`; an operator's stop; kill -9 during a walk; the
// daemon's peak RSS over a walk of 300 keyframes.
#include <Eigen/Geometry>
#include <fstream>
#include <optional>
#include <vector>

#include "entry/mesh_gltf.h"
#include "entry/walk_entry.h"
#include "tests/integration/daemon_process.h"
#include "tests/support/run_command.h"
#include "tests/support/synth_fixture.h"
#include "tests/support/temp_dir.h"

namespace mm::test {
namespace {

// The corridor of every test here (round its corner, 300 frames at 30 Hz, 640x480 pinhole):
// ctest's fixture synth/corridor_walk_seed2 (tests/CMakeLists.txt), shared with eval_walk_test;
// the tests only read it (each daemon has its own folder and spool).
const fs::path& Corridor() {
  static const fs::path seq = [] {
    std::string error;
    fs::path made = SynthFixture(kCorridorWalkSeed2, FreshTempDir("walk_corridor"), &error);
    EXPECT_FALSE(made.empty()) << error;
    return made;
  }();
  return seq;
}

// The walk's last result once walk `id` has ended (null on timeout).
json WaitForWalk(DaemonProcess& daemon, uint64_t id, std::chrono::seconds timeout) {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  while (std::chrono::steady_clock::now() < deadline) {
    const json last = daemon.Status()["walk"]["last_result"];
    if (last.is_object() && last["walk"].get<uint64_t>() == id) return last;
    std::this_thread::sleep_for(100ms);
  }
  ADD_FAILURE() << "walk " << id << " did not end; log:\n" << daemon.log();
  return json();
}

void WaitForKeyframes(DaemonProcess& daemon, int keyframes, std::chrono::seconds timeout) {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  while (std::chrono::steady_clock::now() < deadline) {
    if (daemon.Status()["walk"]["keyframes"].get<int>() >= keyframes) return;
    std::this_thread::sleep_for(50ms);
  }
  ADD_FAILURE() << "fewer than " << keyframes << " keyframes; log:\n" << daemon.log();
}

// Peak resident set of a process (VmHWM, kB).
long PeakRssKb(pid_t pid) {
  std::ifstream in("/proc/" + std::to_string(pid) + "/status");
  std::string line;
  while (std::getline(in, line)) {
    if (line.rfind("VmHWM:", 0) == 0) return std::stol(line.substr(6));
  }
  return -1;
}

WalkReport ReadWalk(const fs::path& entry) {
  WalkReport report;
  EXPECT_EQ(ReadWalkReport(entry, &report), "") << entry;
  return report;
}

TEST(DaemonWalk, ReplayedCorridorIsOneMapThatEvalSpoolChecks) {
  ASSERT_FALSE(Monomesh().empty()) << "MONOMESH is not set (run through ctest)";
  const fs::path seq = Corridor();
  // Scaled from the floor at the eye's height (docs/scale.md): the entry is in metres.
  DaemonProcess daemon("walk", "rate=realtime&loop=0",
                       "[scale]\nsource = \"floor\"\ncamera_height_m = 1.6\n", seq, "",
                       seq / "calib.toml");
  daemon.Start();
  // The walk's events, watched from before its start to its entry.
  EventWatch watch(daemon.socket(), {"walk_entry", "walk_failed"}, 240);
  const std::optional<json> first = watch.Next();
  ASSERT_TRUE(first) << daemon.log();
  ASSERT_TRUE(first->value("watching", false)) << first->dump();
  const json started = daemon.Command("walk start");
  ASSERT_TRUE(started.value("ok", false)) << started.dump();
  // A capture is refused while walking, naming the state.
  const json trigger = daemon.Command("trigger");
  EXPECT_FALSE(trigger.value("ok", true));
  EXPECT_EQ(trigger.value("error", ""), "busy: walking");
  const json last = WaitForWalk(daemon, started["walk"].get<uint64_t>(), 180s);
  ASSERT_TRUE(last.value("ok", false)) << last.dump() << "\n" << daemon.log();
  std::vector<json> frame_events;
  while (std::optional<json> e = watch.Next()) {
    if ((*e)["event"] == "walk_frame") frame_events.push_back(*e);
  }
  EXPECT_EQ(watch.Close(), 0) << daemon.log();
  EXPECT_EQ(last["reason"], "camera ended");
  EXPECT_EQ(last["segments"], 1) << daemon.log();
  const fs::path entry = last["entry"].get<std::string>();
  const WalkReport report = ReadWalk(entry);
  EXPECT_TRUE(report.success) << report.failure_reason;
  EXPECT_GE(report.counts.keyframes, 10);
  // Every keyframe is in the map, but for a few lost ones (not in the map, never in another
  // segment): the walk thread takes the newest frame when it is free, and on a loaded machine
  // the frames it sees round the corner are a metre apart (measured: 2 of 13 lost with both
  // cores busy, none on an idle machine).
  EXPECT_GE(report.counts.registered, 10) << daemon.log();
  EXPECT_LE(report.counts.keyframes - report.counts.registered, 2) << daemon.log();
  for (const WalkReport::Keyframe& k : report.keyframes) {
    if (!k.registered) {
      EXPECT_EQ(k.failure.rfind("lost: ", 0), 0u) << k.failure;
    }
  }
  for (const char* f :
       {"map.glb", "map.ply", "trajectory.txt", "points.ply", "cameras.txt", "images.txt",
        "points3D.txt", "calibration.toml", "preview.png", "report.json"}) {
    EXPECT_TRUE(fs::exists(entry / f)) << entry << " lacks " << f;
  }
  for (const WalkReport::Keyframe& k : report.keyframes) {
    EXPECT_TRUE(fs::exists(entry / k.image)) << k.image;
  }
  // The walk's progress as it went: walk_frame events of this walk, 5 a second at most, their
  // frame and keyframe counts growing to the entry's.
  ASSERT_GE(frame_events.size(), 10u) << daemon.log();
  for (size_t i = 0; i < frame_events.size(); ++i) {
    const json& e = frame_events[i];
    EXPECT_EQ(e["walk"], started["walk"]) << e.dump();
    EXPECT_TRUE(e["walking"].get<bool>()) << e.dump();
    EXPECT_LE(e["tracked_frames"].get<uint64_t>(), e["frames"].get<uint64_t>()) << e.dump();
    if (i == 0) continue;
    const json& before = frame_events[i - 1];
    EXPECT_GT(e["frames"].get<uint64_t>(), before["frames"].get<uint64_t>()) << e.dump();
    EXPECT_GE(e["keyframes"].get<int>(), before["keyframes"].get<int>()) << e.dump();
    EXPECT_GE(e["time_ns"].get<int64_t>() - before["time_ns"].get<int64_t>(), 200'000'000)
        << e.dump();
  }
  EXPECT_LE(frame_events.back()["frames"].get<uint64_t>(), report.frames);
  EXPECT_LE(frame_events.back()["keyframes"].get<int>(), report.counts.keyframes);
  EXPECT_GE(frame_events.back()["keyframes"].get<int>(), report.counts.keyframes - 3);
  std::cout << "[ figures  ] " << frame_events.size() << " walk_frame events, the last at frame "
            << frame_events.back()["frames"] << " of " << report.frames << ", keyframe "
            << frame_events.back()["keyframes"] << " of " << report.counts.keyframes << "\n";
  // trajectory.txt: one TUM line per registered keyframe of the map segment.
  std::ifstream trajectory(entry / "trajectory.txt");
  int poses = 0;
  for (std::string line; std::getline(trajectory, line);) poses += !line.empty() && line[0] != '#';
  EXPECT_EQ(poses, report.counts.registered);
  // The map mesh: parts textured by their keyframes, a surface of thousands of triangles.
  Mesh map;
  cv::Mat texture;
  EXPECT_EQ(DecodeGlb(ReadFile(entry / "map.glb"), &map, &texture), "");
  EXPECT_FALSE(texture.empty());
  EXPECT_GE(report.counts.mesh_triangles, 2000);
  EXPECT_GE(report.counts.mesh_parts, 3);
  // The map was refined before its mesh ([walk] refine, on by default): most overlapping pairs
  // of the corridor's keyframes verify (measured 267 of 272 in eval), thousands of points.
  EXPECT_TRUE(report.refinement.ran) << report.refinement.skipped;
  EXPECT_GE(report.refinement.verified_pairs, report.counts.registered);
  EXPECT_GE(report.refinement.points, 1000);
  EXPECT_GT(report.timings_s.refinement, 0.0);
  std::cout << "walk: " << report.counts.keyframes << " keyframes, " << report.frames
            << " frames, mesh " << report.counts.mesh_parts << " parts ("
            << report.counts.mesh_dense_parts << " dense), " << report.counts.mesh_triangles
            << " triangles; registration median " << report.timings_s.registration_median
            << " s; peak RSS " << PeakRssKb(daemon.pid()) / 1024 << " MB\n";

  // The trajectory against the exact ground truth, through the CLI.
  int status = 0;
  const fs::path out = daemon.dir() / "eval.json";
  const std::string text = RunCommand(Monomesh() + " eval --dataset " + seq.string() + " --spool " +
                                          daemon.spool().string() + " --json " + out.string(),
                                      &status);
  ASSERT_EQ(status, 0) << text;
  std::cout << text;
  const json eval = json::parse(ReadFile(out));
  EXPECT_EQ(eval["summary"]["walks_evaluated"], 1);
  // In metres: the similarity that aligns the trajectory to the truth has scale 1.
  EXPECT_EQ(report.scale.source, "floor") << report.scale.why_not;
  EXPECT_EQ(report.scale.units, "metres");
  const double sim3_scale = eval["entries"][0]["walk"]["sim3_scale"].get<double>();
  std::cout << "[ figures  ] walk scale from the floor: " << report.scale.metres_per_unit
            << " m per unit, " << report.scale.uncertainty_rel
            << " relative sigma; the truth's alignment scale " << sim3_scale << "\n";
  EXPECT_NEAR(sim3_scale, 1.0, 0.02);  // Measured 1.004; the issue asks 2 % (median).
  // The target for the walk: ATE RMSE <= 0.5 % of the path (measured 0.02-0.03 %).
  EXPECT_LE(eval["summary"]["walk_ate_rel_max"].get<double>(), 0.005);
  EXPECT_GE(eval["entries"][0]["walk"]["path_length_m"].get<double>(), 5.0);
}

TEST(DaemonWalk, OperatorStopWritesTheWalkAndKillNineLeavesNoPartialEntry) {
  ASSERT_FALSE(Monomesh().empty()) << "MONOMESH is not set (run through ctest)";
  const fs::path seq = Corridor();
  DaemonProcess daemon("walkstop", "rate=realtime&loop=1", "", seq, "", seq / "calib.toml");
  daemon.Start();
  EXPECT_FALSE(daemon.Command("walk stop").value("ok", true));  // Not walking.
  const json first = daemon.Command("walk start");
  ASSERT_TRUE(first.value("ok", false)) << first.dump();
  WaitForKeyframes(daemon, 4, 60s);
  const json stop = daemon.Command("walk stop");
  EXPECT_TRUE(stop.value("ok", false)) << stop.dump();
  const json last = WaitForWalk(daemon, first["walk"].get<uint64_t>(), 120s);
  ASSERT_TRUE(last.value("ok", false)) << last.dump();
  EXPECT_EQ(last["reason"], "operator");
  const fs::path entry = last["entry"].get<std::string>();
  EXPECT_EQ(ReadWalk(entry).stop_reason, "operator");
  EXPECT_EQ(daemon.Status()["state"], "idle");

  // kill -9 during the next walk: nothing of it becomes visible, the first entry stays whole.
  const json second = daemon.Command("walk start");
  ASSERT_TRUE(second.value("ok", false)) << second.dump();
  WaitForKeyframes(daemon, 3, 60s);
  daemon.Kill(SIGKILL);
  EXPECT_EQ(VisibleEntries(daemon.spool()).size(), 1u);
  daemon.Start();  // Recovers the spool.
  const std::vector<fs::path> entries = VisibleEntries(daemon.spool());
  ASSERT_EQ(entries.size(), 1u);
  EXPECT_EQ(entries[0].filename(), entry.filename());
  EXPECT_TRUE(ReadWalk(entries[0]).success);
  for (const auto& item : fs::directory_iterator(daemon.spool())) {
    EXPECT_NE(item.path().filename().string().rfind(".tmp-", 0), 0u) << item.path();
  }
}

// A long walk: a keyframe at the reconstruction's smallest parallax (1 deg), up to the limit of
// 300 (the corridor replayed in a loop: the jump back to its start is relocalised and each lap
// closes a loop, so on an idle machine the map is one segment of all 300 keyframes and its mesh
// reaches its cap of 64 parts; measured 434 and 457 MB peak).
TEST(DaemonWalk, ThreeHundredKeyframesKeepThePeakRssUnder500MB) {
  ASSERT_FALSE(Monomesh().empty()) << "MONOMESH is not set (run through ctest)";
  const fs::path seq = Corridor();
  DaemonProcess daemon("walklong", "rate=realtime&loop=1",
                       "[walk]\nparallax_deg = 1.0\nmax_keyframes = 300\n", seq, "",
                       seq / "calib.toml");
  daemon.Start();
  const json started = daemon.Command("walk start");
  ASSERT_TRUE(started.value("ok", false)) << started.dump();
  const json last = WaitForWalk(daemon, started["walk"].get<uint64_t>(), 600s);
  ASSERT_TRUE(last.value("ok", false)) << last.dump();
  EXPECT_EQ(last["reason"], "keyframe limit");
  EXPECT_EQ(last["keyframes"], 300);
  const long peak_kb = PeakRssKb(daemon.pid());
  // How many loops closed and how many background adjustments of the segment ran (the
  // walk's thread takes the newest frame when free, so both vary with the machine's load).
  const std::string log = daemon.log();
  auto count = [&log](const std::string& what) {
    int n = 0;
    for (size_t at = log.find(what); at != std::string::npos; at = log.find(what, at + 1)) ++n;
    return n;
  };
  std::cout << "300 keyframes (" << last["segments"] << " segments, " << count("closed a loop")
            << " loops, " << count("bundle adjustment after the loop applied")
            << " background adjustments): peak RSS " << peak_kb / 1024 << " MB\n";
  EXPECT_GT(peak_kb, 0);
  EXPECT_LE(peak_kb, 500 * 1024);
}

}  // namespace
}  // namespace mm::test
