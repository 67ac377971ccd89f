// `monomesh eval --scale` (scale/metric_scale.h through eval/tum_pairs.h): metric scale per pair
// against the ground truth's (its baseline over the reconstruction's). The TUM keyframes with
// the odometry simulated from the ground truth (1 cm noise per position), and the synthetic
// corridor walk at its known eye height with the floor source.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>

#include "tests/support/monomesh_eval.h"
#include "tests/support/shared_data.h"
#include "tests/support/synth_fixture.h"
#include "tests/support/temp_dir.h"

namespace mm::test {
namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;

fs::path TempDir(const std::string& name) { return FreshTempDir("eval_scale_" + name); }

json ScaleEval(const std::string& args, const fs::path& json_file) {
  return RunMonomeshEval("--quiet " + args, json_file);
}

TEST(EvalScale, TumKeyframesFromOdometryWithCentimetreNoise) {
  ASSERT_FALSE(Monomesh().empty()) << "MONOMESH is not set (run through ctest)";
  const fs::path data = RequireSharedData("tum_fr3_long_office_household");
  const fs::path dir = TempDir("tum");
  const std::string common = "--dataset " + data.string() +
                             " --calib " MM_SOURCE_DIR
                             "/data/tum_office/calib.toml --list keyframes_1hz.txt --scale "
                             "odometry --odom-seed 1 ";
  const json noisy = ScaleEval(common + "--odom-noise-m 0.01", dir / "noisy.json");
  const json& s = noisy["summary"]["scale"];
  std::cout << "[ figures  ] 1 cm odometry noise: " << s.dump() << "\n";
  EXPECT_EQ(s["pairs"].get<int>(), 16);
  // The target 5 %; measured 3.4 % (p90 8.4 %, seed 1).
  EXPECT_LE(s["rel_err_median"].get<double>(), 0.05);
  for (const json& p : noisy["pairs"]) {
    EXPECT_EQ(p["scale"]["source"], "odometry") << p.dump();
    EXPECT_GT(p["scale"]["uncertainty_rel"].get<double>(), 0.0);
  }
  // Exact odometry: the ground truth's own baseline, so only the plumbing can err.
  const json exact = ScaleEval(common + "--odom-noise-m 0", dir / "exact.json");
  EXPECT_LE(exact["summary"]["scale"]["rel_err_median"].get<double>(), 0.005);
  fs::remove_all(dir);
}

// The walk (eye at 1.6 m, 2 cm bob, nods and roll; docs/synth.md), every 10th of 240 frames at
// 30 fps as keyframes: pairs 1/3 s apart; the floor is the textured corridor floor, out of view
// at the corner.
TEST(EvalScale, SynthCorridorWalkFromTheFloorAtEyeHeight) {
  ASSERT_FALSE(Monomesh().empty()) << "MONOMESH is not set (run through ctest)";
  const fs::path dir = TempDir("walk");
  // ctest's fixture synth/corridor_walk_seed3 (tests/CMakeLists.txt), shared with
  // eval_captures_test; the list of every 10th frame (absolute paths) goes to this test's folder.
  std::string error;
  const fs::path seq = SynthFixture(kCorridorWalkSeed3, dir, &error);
  ASSERT_FALSE(seq.empty()) << error;
  {
    std::ifstream in(seq / "rgb.txt");
    std::ofstream list(dir / "every10.txt");
    std::string line;
    int n = 0;
    while (std::getline(in, line)) {
      if (line.empty() || line[0] == '#') continue;
      std::istringstream fields(line);
      std::string timestamp, file;
      fields >> timestamp >> file;
      if (n++ % 10 == 0) list << timestamp << " " << (seq / file).string() << "\n";
    }
  }
  const json r = ScaleEval(
      "--dataset " + seq.string() + " --calib " + (seq / "calib.toml").string() + " --list " +
          (dir / "every10.txt").string() + " --scale floor --camera-height-m 1.6",
      dir / "walk.json");
  const json& s = r["summary"]["scale"];
  std::cout << "[ figures  ] walk, floor at 1.6 m: " << s.dump() << "\n";
  // The floor from the room's planes, its normal from the walls and every horizontal plane
  // (scale/room_planes.h). Measured: 15 of 23 pairs scaled, median 1.22 %, p90 3.06 % (the
  // issue's targets 2 % and 5 %); the eye's 2 cm bob alone is 1.3 % of its height. The 8 pairs
  // at the corner face the end wall with 0-5 % of the image on the floor (the ground truth's
  // depth) and say "no floor in view" rather than take a box top or a slice of wall for it.
  EXPECT_GE(s["pairs"].get<int>(), 14);
  EXPECT_LE(s["rel_err_median"].get<double>(), 0.02);
  EXPECT_LE(s["rel_err_p90"].get<double>(), 0.05);
  int no_floor = 0;
  for (const json& p : r["pairs"]) {
    if (!p.value("success", false) || p["scale"]["source"] != "none") continue;
    EXPECT_NE(p["scale"]["why_not"].get<std::string>().find("no floor in view"), std::string::npos)
        << p.dump();
    ++no_floor;
  }
  EXPECT_EQ(no_floor, s["asked"].get<int>() - s["pairs"].get<int>());
  fs::remove_all(dir);
}

}  // namespace
}  // namespace mm::test
