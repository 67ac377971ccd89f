// monomeshd on the synthetic corridor (issue 9): `monomesh synth` writes a walk and a pure
// rotation through a distorted camera, the replay camera plays them at 30 fps in real time,
// and every capture is checked against the exact ground truth; `monomesh eval` reports the same
// pairs from the folder. The rotation never yields keyframe B.
#include <Eigen/Geometry>
#include <cstdio>
#include <iomanip>

#include "dataset/tum.h"
#include "tests/integration/daemon_process.h"
#include "tests/support/run_command.h"
#include "tests/support/temp_dir.h"

namespace mm::test {
namespace {

// The distorted 320x240 board camera (shared with the kernel stage): the frames are distorted
// with it, so the daemon's undistortion runs on every frame.
const fs::path kBoardCamera = fs::path(MM_SOURCE_DIR) / "tests/support/board_camera.toml";

// `monomesh synth` into <tmp>/mm_synth_<name>_<pid>/ with the distorted camera.
fs::path Synthesize(const std::string& name, const std::string& path, int frames) {
  const fs::path dir = FreshTempDir("synth_" + name);
  int status = 0;
  const std::string out =
      RunCommand(Monomesh() + " synth --scene l-corridor --out " + (dir / "seq").string() +
                     " --frames " + std::to_string(frames) + " --fps 30 --calib " +
                     kBoardCamera.string() + " --seed 3 --path " + path,
                 &status);
  EXPECT_EQ(status, 0) << out;
  std::cout << out;
  return dir / "seq";
}

Eigen::Isometry3d RelativePose(const EntryReport& report) {
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.linear() = report.relative_pose.rotation;
  pose.translation() = report.relative_pose.translation;
  return pose;
}

TEST(DaemonSynth, WalkMeshesMatchTheExactGroundTruth) {
  ASSERT_FALSE(Monomesh().empty()) << "MONOMESH is not set (run through ctest)";
  const fs::path seq = Synthesize("walk", "walk", 150);  // 5 s, 5 m of corridor.
  // The gate at its defaults (the reconstruction's own test, 2 deg of triangulation angle).
  DaemonProcess daemon("synthwalk", "rate=realtime&loop=0", "[keyframes]\ntimeout_s = 3.0\n", seq,
                       "", seq / "calib.toml");
  daemon.Start();
  const Trajectory gt = Trajectory::Read(seq / "groundtruth.txt");
  const double last_time = gt.poses().back().timestamp_s;
  std::vector<fs::path> entries;
  // Capture after capture while at least ~1.5 s of the walk is left to find keyframe B in.
  for (int attempt = 0; attempt < 6; ++attempt) {
    const json status = daemon.Status();
    if (status["camera"]["end_of_stream"].get<bool>()) break;
    const json result = daemon.TriggerAndWait(30s);
    ASSERT_TRUE(result.value("ok", false)) << result.dump() << "\n" << daemon.log();
    entries.emplace_back(result["entry"].get<std::string>());
    if (ReadReport(entries.back()).keyframe_b.source_time_s > last_time - 2.0) break;
  }
  ASSERT_GE(entries.size(), 2u) << daemon.log();

  std::vector<double> rot_errors, dir_errors;
  for (size_t k = 0; k < entries.size(); ++k) {
    ExpectCompleteEntry(entries[k]);
    const EntryReport report = ReadReport(entries[k]);
    const KeyframeInfo& a = report.keyframe_a;
    const KeyframeInfo& b = report.keyframe_b;
    // The dense sweep took the gate's frame about halfway beside B.
    EXPECT_EQ(report.meshing.mode, "dense");
    EXPECT_EQ(report.meshing.dense_views_between, 1) << report.meshing.dense_views_left_out;
    // From the second capture on, the daemon holds frames of the walk before A: one of them,
    // A's corners tracked back to it, is swept beside B too.
    std::cout << "[ figures  ] mesh " << k << ": dense views " << report.meshing.dense_views_between
              << " between + " << report.meshing.dense_views_before_a << " before A, dense "
              << report.meshing.dense_valid_fraction << " of A\n";
    // Measured: 0.85 of A with a dense depth without it (the first capture), 0.96-0.99 with
    // (the depth edges cut back to A's outlines take 0-2 points; the replay's timing moves it).
    if (k > 0) {
      EXPECT_EQ(report.meshing.dense_views_before_a, 1) << report.meshing.dense_views_left_out;
      EXPECT_GE(report.meshing.dense_valid_fraction, 0.93);
    }
    const auto world_from_a = gt.WorldFromCamAt(a.source_time_s, 0.0);
    const auto world_from_b = gt.WorldFromCamAt(b.source_time_s, 0.0);
    ASSERT_TRUE(world_from_a && world_from_b);
    const Eigen::Isometry3d truth = CamBFromCamA(*world_from_a, *world_from_b);
    const Eigen::Isometry3d estimate = RelativePose(report);
    const double rot = RotationErrorDeg(estimate.linear(), truth.linear());
    const double dir = DirectionErrorDeg(estimate.translation(), truth.translation());
    rot_errors.push_back(rot);
    dir_errors.push_back(dir);

    // `monomesh eval` on the same pair of the folder (the two frames as a list).
    const fs::path list = daemon.dir() / ("pair" + std::to_string(k) + ".txt");
    std::ofstream(list) << std::fixed << std::setprecision(6) << a.source_time_s << " " << a.source
                        << "\n"
                        << b.source_time_s << " " << b.source << "\n";
    const fs::path eval_json = daemon.dir() / ("eval" + std::to_string(k) + ".json");
    int status = 0;
    const std::string eval_out =
        RunCommand(Monomesh() + " eval --dataset " + seq.string() + " --calib " +
                       (seq / "calib.toml").string() + " --list " + list.string() + " --json " +
                       eval_json.string(),
                   &status);
    ASSERT_EQ(status, 0) << eval_out;
    const json eval = json::parse(ReadFile(eval_json));
    const json& pair = eval["pairs"][0];
    std::cout << "[ figures  ] mesh " << k << ": frames "
              << a.source.substr(seq.string().size() + 5) << " -> "
              << b.source.substr(seq.string().size() + 5) << " (baseline "
              << truth.translation().norm() << " m, turn "
              << RotationErrorDeg(Eigen::Matrix3d::Identity(), truth.linear())
              << " deg): daemon rotation error " << rot << " deg, translation direction " << dir
              << " deg; eval " << eval_out.substr(0, eval_out.find('\n')) << "\n";
    EXPECT_TRUE(pair["success"].get<bool>()) << eval_out;
    EXPECT_NEAR(pair["gt_baseline_m"].get<double>(), truth.translation().norm(), 1e-6);
    EXPECT_LT(pair["rot_err_deg"].get<double>(), 0.1) << eval_out;
    EXPECT_LT(pair["trans_err_deg"].get<double>(), 1.0) << eval_out;
  }
  // Measured (seed 3, 320x240 distorted, two runs of six meshes, 0.23-0.30 m baselines): rotation
  // errors 0.003-0.028 deg, translation directions 0.05-0.35 deg; eval the same to 0.001 deg.
  for (size_t k = 0; k < entries.size(); ++k) {
    EXPECT_LT(rot_errors[k], 0.1) << "mesh " << k;
    EXPECT_LT(dir_errors[k], 1.0) << "mesh " << k;
  }
  EXPECT_EQ(WEXITSTATUS(daemon.Kill(SIGTERM)), 0);
  if (!HasFailure()) fs::remove_all(seq.parent_path());  // Kept for a look when it failed.
}

TEST(DaemonSynth, PureRotationNeverTakesKeyframeB) {
  ASSERT_FALSE(Monomesh().empty()) << "MONOMESH is not set (run through ctest)";
  const fs::path seq = Synthesize("rotate", "rotate", 120);  // 4 s of panning and tilting.
  // The appliance's gate settings; the capture gives up after 3 s.
  DaemonProcess daemon("synthrotate", "rate=realtime&loop=0", "[keyframes]\ntimeout_s = 3.0\n", seq,
                       "", seq / "calib.toml");
  daemon.Start();
  const json reply = daemon.Command("trigger");
  ASSERT_TRUE(reply.value("ok", false)) << reply.dump();
  // Watch the gate while it tracks: the largest triangulation angle it reports (0 while the
  // reconstruction's classification calls the motion a rotation).
  double max_parallax = 0;
  int min_tracks = 1 << 30;
  json result;
  const auto deadline = std::chrono::steady_clock::now() + 30s;
  while (std::chrono::steady_clock::now() < deadline) {
    const json status = daemon.Status();
    if (status["state"] == "tracking") {
      max_parallax = std::max(max_parallax, status["gate"]["parallax_deg"].get<double>());
      min_tracks = std::min(min_tracks, status["gate"]["tracks"].get<int>());
    }
    const json& last = status["last_result"];
    if (last.is_object() && last["capture"] == reply["capture"]) {
      result = last;
      break;
    }
    std::this_thread::sleep_for(20ms);
  }
  ASSERT_TRUE(result.is_object()) << daemon.log();
  EXPECT_FALSE(result.value("ok", true)) << result.dump();
  EXPECT_NE(result.value("error", "").find("not enough motion"), std::string::npos)
      << result.dump() << "\n"
      << daemon.log();
  EXPECT_EQ(daemon.log().find("keyframe B ="), std::string::npos) << daemon.log();
  EXPECT_TRUE(VisibleEntries(daemon.spool()).empty());
  // The operator's view: `monomesh ctl status` shows the failed capture and the gate's reason.
  int status = 0;
  const std::string ctl =
      RunCommand(Monomesh() + " ctl status --socket " + daemon.socket().string(), &status);
  EXPECT_EQ(status, 0) << ctl;
  EXPECT_NE(ctl.find("not enough motion"), std::string::npos) << ctl;
  std::cout << "[ figures  ] rotation: " << result.value("error", "")
            << "; while tracking: max parallax " << max_parallax << " deg, min tracks "
            << min_tracks << "\n";
  // Measured (seed 3, 320x240 distorted): max parallax 0.076 deg, a quarter of the 0.3 deg gate
  // (with parallax_deg = 0.05 the gate does take B, and the recon then reports "pure rotation").
  EXPECT_LT(max_parallax, 0.15);
  EXPECT_GT(min_tracks, 40);
  if (!HasFailure()) fs::remove_all(seq.parent_path());
}

}  // namespace
}  // namespace mm::test
