// The daemon's keyframe gate on 16 consecutive TUM frames (30 Hz, ~2 cm of motion; data that
// may not be committed, so the binary skips with 77 without ../shared/data).
#include "tests/integration/daemon_process.h"
#include "tests/support/shared_data.h"

namespace mm::test {
namespace {

fs::path TumFolder() { return RequireSharedData("tum_fr3_long_office_household"); }

TEST(DaemonGate, SixteenTumFramesDoNotPassThreeDegrees) {
  DaemonProcess daemon("gate3", "rate=realtime&loop=0", "", TumFolder());
  std::ofstream(daemon.dir() / "monomeshd.toml", std::ios::app)
      << "[keyframes]\nparallax_deg = 3.0\ntimeout_s = 2.0\n";
  daemon.Start();
  const json result = daemon.TriggerAndWait(30s);
  EXPECT_FALSE(result.value("ok", true)) << result.dump();
  EXPECT_NE(result.value("error", "").find("not enough motion"), std::string::npos)
      << result.dump();
  EXPECT_EQ(daemon.log().find("keyframe B ="), std::string::npos) << daemon.log();
}

TEST(DaemonGate, SixteenTumFramesPassASmallThreshold) {
  DaemonProcess daemon("gatesmall", "rate=realtime&loop=0", "", TumFolder());
  std::ofstream(daemon.dir() / "monomeshd.toml", std::ios::app)
      << "[keyframes]\nparallax_deg = 0.05\ntimeout_s = 2.0\n"
      // With 2 cm of baseline a 1 px homography still explains 74-82 % of the tracks
      // (measured), so the model test is relaxed too; pure rotation stays below 0.02 deg.
      << "max_homography_inlier_ratio = 0.95\n";
  daemon.Start();
  const json result = daemon.TriggerAndWait(60s);
  // Keyframe B is taken; whether 2 cm of baseline reconstructs is the recon's business.
  EXPECT_NE(daemon.log().find("keyframe B ="), std::string::npos) << daemon.log();
  EXPECT_EQ(result.value("error", "").find("not enough motion"), std::string::npos)
      << result.dump();
}

}  // namespace
}  // namespace mm::test
