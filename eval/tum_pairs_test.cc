// The evaluations against ground truth refuse a folder without it (they printed 0.000 deg
// errors and "5/5 pairs succeeded" on one).
#include "eval/tum_pairs.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <fstream>

#include "calib/calib_io.h"
#include "eval/capture_eval.h"
#include "tests/support/temp_dir.h"

namespace mm {
namespace {

namespace fs = std::filesystem;

const fs::path kData = fs::path(MM_SOURCE_DIR) / "data/tum_office";

fs::path CopyWithoutGroundTruth(const std::string& name) {
  const fs::path dir = test::TestTempPath("eval_nogt_" + name);
  fs::remove_all(dir);
  fs::copy(kData, dir, fs::copy_options::recursive);
  fs::remove(dir / "groundtruth.txt");
  return dir;
}

TEST(EvaluateTumPairs, FolderWithoutGroundTruthFailsNamingTheFile) {
  const fs::path dir = CopyWithoutGroundTruth("pairs");
  const EvalResult r = EvaluateTumPairs(dir, LoadCalibration(kData / "calib.toml"), {});
  EXPECT_FALSE(r.ok);
  EXPECT_TRUE(r.pairs.empty());
  EXPECT_NE(r.failure_reason.find((dir / "groundtruth.txt").string() + ": missing"),
            std::string::npos)
      << r.failure_reason;
  fs::remove_all(dir);
}

TEST(EvaluateCaptures, FolderWithoutGroundTruthFailsNamingTheFile) {
  const fs::path dir = CopyWithoutGroundTruth("captures");
  const CaptureEvalResult r = EvaluateCaptures(dir, LoadCalibration(kData / "calib.toml"), {});
  EXPECT_FALSE(r.ok);
  EXPECT_TRUE(r.captures.empty());
  EXPECT_NE(r.failure_reason.find((dir / "groundtruth.txt").string() + ": missing"),
            std::string::npos)
      << r.failure_reason;
  fs::remove_all(dir);
}

// A ground truth that covers none of the frames (here: another recording's times) is as good
// as none.
TEST(EvaluateTumPairs, GroundTruthCoveringNoPairFails) {
  const fs::path dir = CopyWithoutGroundTruth("elsewhen");
  std::ofstream(dir / "groundtruth.txt") << "# timestamp tx ty tz qx qy qz qw\n"
                                         << "100.0 0 0 0 0 0 0 1\n100.1 0 0 0 0 0 0 1\n";
  std::ofstream(dir / "two.txt") << "1341847980.722988 rgb/1341847980.722988.png\n"
                                 << "1341847981.726650 rgb/1341847981.726650.png\n";
  EvalOptions options;
  options.list = dir / "two.txt";
  const EvalResult r = EvaluateTumPairs(dir, LoadCalibration(kData / "calib.toml"), options);
  EXPECT_FALSE(r.ok);
  EXPECT_NE(r.failure_reason.find("no pose within"), std::string::npos) << r.failure_reason;
  fs::remove_all(dir);
}

}  // namespace
}  // namespace mm
