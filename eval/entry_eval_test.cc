// Spool entries against ground truth: exact poses give zero error, a known perturbation its
// angle, device timestamps map through the feed log, and unmappable keyframes are reported.

#include "eval/entry_eval.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <Eigen/Geometry>
#include <filesystem>
#include <fstream>
#include <iomanip>

#include "entry/report.h"
#include "tests/support/temp_dir.h"

namespace mm {
namespace {

namespace fs = std::filesystem;

EntryEvalOptions Options(const fs::path& spool, const fs::path& dataset,
                         const fs::path& feed_log = {}) {
  EntryEvalOptions o;
  o.spool = spool;
  o.dataset = dataset;
  o.feed_log = feed_log;
  return o;
}

class EntryEvalTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = test::FreshTempDir("entry_eval");
    fs::create_directories(dir_ / "spool");
    // world_from_cam: identity at t=100; at t=101 moved 0.5 m along x and yawed 10 deg.
    const Eigen::Quaterniond q(Eigen::AngleAxisd(10.0 * M_PI / 180, Eigen::Vector3d::UnitY()));
    std::ofstream(dir_ / "groundtruth.txt")
        << std::setprecision(17) << "# t tx ty tz qx qy qz qw\n"
        << "100 0 0 0 0 0 0 1\n"
        << "101 0.5 0 0 " << q.x() << " " << q.y() << " " << q.z() << " " << q.w() << "\n";
    world_from_b_.linear() = q.toRotationMatrix();
    world_from_b_.translation() = Eigen::Vector3d(0.5, 0, 0);
  }
  void TearDown() override { fs::remove_all(dir_); }

  // An entry whose estimate is the true relative pose, rotated by `extra_deg` about x.
  void WriteReport(const std::string& name, double time_a, double time_b, double extra_deg) {
    const Eigen::Isometry3d b_from_a = world_from_b_.inverse();  // world_from_a = identity.
    const Eigen::Matrix3d r =
        Eigen::AngleAxisd(extra_deg * M_PI / 180, Eigen::Vector3d::UnitX()) * b_from_a.linear();
    const Eigen::Vector3d t = b_from_a.translation() * 3.0;  // Scale is unobservable.
    EntryReport report;
    report.success = true;
    report.keyframe_a.source_time_s = time_a;
    report.keyframe_b.source_time_s = time_b;
    report.relative_pose.rotation = r;
    report.relative_pose.translation = t;
    report.counts.mesh_vertices = 321;
    fs::create_directories(dir_ / "spool" / name);
    std::ofstream(dir_ / "spool" / name / "report.json") << FormatEntryReport(report);
  }

  fs::path dir_;
  Eigen::Isometry3d world_from_b_ = Eigen::Isometry3d::Identity();
};

TEST_F(EntryEvalTest, DatasetTimesGiveExactAndPerturbedErrors) {
  WriteReport("e1", 100, 101, 0.0);
  WriteReport("e2", 100, 101, 1.5);
  fs::create_directories(dir_ / "spool" / ".tmp-e3");  // An unfinished entry is not one.
  const EntryEvalResult r = EvaluateSpoolEntries(Options(dir_ / "spool", dir_));
  ASSERT_TRUE(r.ok) << r.failure_reason;
  ASSERT_EQ(r.entries.size(), 2u);
  EXPECT_EQ(r.evaluated, 2);
  EXPECT_NEAR(r.entries[0].rot_err_deg, 0.0, 1e-6);
  EXPECT_NEAR(r.entries[0].trans_err_deg, 0.0, 1e-6);
  EXPECT_NEAR(r.entries[0].baseline_m, 0.5, 1e-9);
  EXPECT_NEAR(r.entries[0].gt_rotation_deg, 10.0, 1e-6);
  EXPECT_NEAR(r.entries[1].rot_err_deg, 1.5, 1e-6);
  EXPECT_NEAR(r.rot_err_max_deg, 1.5, 1e-6);
  EXPECT_EQ(r.entries[1].mesh_vertices, 321);
}

TEST_F(EntryEvalTest, DeviceTimestampsMapThroughTheFeedLog) {
  std::ofstream(dir_ / "feed.log") << "# write_start_s write_end_s dataset_time_s\n"
                                   << "5.000 5.004 99.966\n5.033 5.037 100\n5.066 5.070 100.033\n"
                                   << "6.033 6.040 101\n";
  WriteReport("e1", 5.0368, 6.0330, 0.0);  // Inside the write intervals of 100 and 101.
  WriteReport("e2", 5.0500, 6.0330, 0.0);  // Keyframe A 13 ms after any write ended.
  const EntryEvalResult r = EvaluateSpoolEntries(Options(dir_ / "spool", dir_, dir_ / "feed.log"));
  ASSERT_TRUE(r.ok) << r.failure_reason;
  ASSERT_EQ(r.entries.size(), 2u);
  EXPECT_TRUE(r.entries[0].evaluated) << r.entries[0].problem;
  EXPECT_DOUBLE_EQ(r.entries[0].time_a_s, 100.0);
  EXPECT_DOUBLE_EQ(r.entries[0].time_b_s, 101.0);
  EXPECT_NEAR(r.entries[0].rot_err_deg, 0.0, 1e-6);
  EXPECT_FALSE(r.entries[1].evaluated);
  EXPECT_NE(r.entries[1].problem.find("keyframe a (device time 5.050000 s) matches no fed frame"),
            std::string::npos)
      << r.entries[1].problem;
}

TEST_F(EntryEvalTest, MissingInputsAreNamed) {
  EntryEvalResult r = EvaluateSpoolEntries(Options(dir_ / "nope", dir_));
  EXPECT_FALSE(r.ok);
  EXPECT_NE(r.failure_reason.find("nope"), std::string::npos);
  r = EvaluateSpoolEntries(Options(dir_ / "spool", dir_ / "spool"));
  EXPECT_NE(r.failure_reason.find("groundtruth.txt"), std::string::npos);
}

}  // namespace
}  // namespace mm
