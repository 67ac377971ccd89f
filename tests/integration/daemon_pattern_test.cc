// The daemon loop on the `test:` pattern camera: no dataset, no device. Frames are counted,
// a trigger starts tracking, a second one is refused while busy, and a still scene ends the
// capture with "not enough motion" after keyframes.timeout_s, back in idle.
#include <iostream>

#include "tests/integration/daemon_process.h"

namespace mm::test {
namespace {

TEST(DaemonPattern, StillSceneEndsTheCaptureWithNotEnoughMotion) {
  // The bundled calibration is 640x480: the pattern has that size.
  DaemonProcess daemon("pattern", CameraUri{"test:still?width=640&height=480&fps=30"},
                       "[keyframes]\ntimeout_s = 1.0\n");
  daemon.Start();
  const json status = daemon.Status();
  EXPECT_EQ(status["state"], "idle") << status.dump();
  EXPECT_GT(status["camera"]["frames"].get<uint64_t>(), 0u) << status.dump();
  // The pattern camera paces itself at 30 Hz; the meter sees what arrives (loose for the
  // sanitizer builds).
  json camera = status["camera"];
  for (int i = 0; i < 40 && camera["frames"].get<uint64_t>() < 15; ++i) {
    std::this_thread::sleep_for(50ms);
    camera = daemon.Status()["camera"];
  }
  std::cout << "[ figures  ] pattern camera at 30 Hz: " << camera["frame_rate_hz"] << " Hz\n";
  EXPECT_GT(camera["frame_rate_hz"].get<double>(), 20.0) << camera.dump();
  EXPECT_LT(camera["frame_rate_hz"].get<double>(), 40.0) << camera.dump();

  const json first = daemon.Command("trigger");
  ASSERT_TRUE(first.value("ok", false)) << first.dump() << "\n" << daemon.log();
  const json busy = daemon.Command("trigger");
  EXPECT_FALSE(busy.value("ok", true)) << busy.dump();
  EXPECT_NE(busy.value("error", "").find("busy"), std::string::npos) << busy.dump();

  json last;
  for (int i = 0; i < 100; ++i) {
    last = daemon.Status()["last_result"];
    if (last.is_object() && last["capture"] == first["capture"]) break;
    std::this_thread::sleep_for(50ms);
  }
  ASSERT_TRUE(last.is_object()) << daemon.log();
  EXPECT_FALSE(last.value("ok", true)) << last.dump();
  EXPECT_NE(last.value("error", "").find("not enough motion"), std::string::npos) << last.dump();
  EXPECT_EQ(daemon.Status()["state"], "idle");
  EXPECT_TRUE(VisibleEntries(daemon.spool()).empty());
}

}  // namespace
}  // namespace mm::test
