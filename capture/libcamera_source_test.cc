// LibcameraSource's process logic against a stand-in worker (capture/fake_libcamera_worker.cc):
// frames read in place from the passed buffers, the loss reported when the worker dies, a new
// worker started with back-off, and the errors that name the worker. libcamera itself is
// tested against vimc in the kernel stage (tests/kernel).

#include "capture/libcamera_source.h"

#include <gtest/gtest.h>

#include <chrono>
#include <cstdlib>
#include <string>

namespace mm {
namespace {

using namespace std::chrono_literals;

LibcameraOptions Fake(const std::string& camera) {
  LibcameraOptions o;
  o.camera = camera;
  o.gray = true;
  o.worker = MM_FAKE_WORKER;
  o.reopen_min_ms = 20;
  o.reopen_max_ms = 100;
  o.lost_after_ms = 2000;
  return o;
}

// Reads until `n` frames arrived, an error, or 10 s. Returns the frames' luma (the fake's count).
std::vector<int> ReadFrames(LibcameraSource* source, int n, std::string* error) {
  std::vector<int> lumas;
  const auto end = std::chrono::steady_clock::now() + 10s;
  while (static_cast<int>(lumas.size()) < n && std::chrono::steady_clock::now() < end) {
    Frame f;
    const ReadStatus s = source->Read(&f, 200ms, error);
    if (s == ReadStatus::kError) break;
    if (s != ReadStatus::kFrame) continue;
    EXPECT_EQ(f.image.type(), CV_8UC1);
    EXPECT_EQ(f.image.size(), cv::Size(64, 48));
    lumas.push_back(f.image.at<uint8_t>(47, 63));
  }
  return lumas;
}

TEST(LibcameraSource, ReadsFramesInPlaceFromTheWorkersBuffers) {
  LibcameraSource source(Fake("fake"));
  ASSERT_EQ(source.Open(), "");
  EXPECT_NE(source.Describe().find("64x48-YUYV -> GRAY8 (worker pid"), std::string::npos)
      << source.Describe();
  std::string error;
  // More frames than buffers: each is handed back and reused.
  const std::vector<int> lumas = ReadFrames(&source, 12, &error);
  ASSERT_EQ(lumas.size(), 12u) << error;
  for (size_t i = 1; i < lumas.size(); ++i) EXPECT_GT(lumas[i], lumas[i - 1]);  // In order, fresh.
  EXPECT_EQ(source.losses(), 0u);
  source.Close();
  EXPECT_EQ(source.worker_pid(), -1);
}

TEST(LibcameraSource, AWorkerThatDiesIsALossAndANewWorkerResumes) {
  LibcameraSource source(Fake("crash-after-5"));
  ASSERT_EQ(source.Open(), "");
  const pid_t first = source.worker_pid();
  std::string error;
  EXPECT_EQ(ReadFrames(&source, 100, &error).size(), 5u);
  EXPECT_NE(error.find("camera lost (camera worker killed by signal 6"), std::string::npos)
      << error;
  EXPECT_EQ(source.losses(), 1u);
  error.clear();
  EXPECT_EQ(ReadFrames(&source, 3, &error).size(), 3u) << error;
  EXPECT_EQ(source.reopens(), 1u);
  EXPECT_NE(source.worker_pid(), first);
}

TEST(LibcameraSource, ErrorsNameTheWorkerAndWhatItSaid) {
  LibcameraSource failing(Fake("fail"));
  EXPECT_EQ(failing.Open(), "libcamera fail: no such camera (fake)");
  // The next two are about starting the program itself: no emulator in front (cross builds
  // set one for the aarch64 workers above).
  const char* launcher = std::getenv("MM_LIBCAMERA_WORKER_LAUNCHER");
  const std::string saved = launcher ? launcher : "";
  unsetenv("MM_LIBCAMERA_WORKER_LAUNCHER");
  LibcameraOptions missing = Fake("fake");
  missing.worker = "/nonexistent/mm-libcamera-worker";
  EXPECT_EQ(
      LibcameraSource(missing).Open(),
      "libcamera fake: cannot start /nonexistent/mm-libcamera-worker: No such file or directory");
  LibcameraOptions silent = Fake("fake");
  silent.worker = "/bin/false";
  EXPECT_EQ(LibcameraSource(silent).Open(),
            "libcamera fake: the camera worker exited 1 (/bin/false)");
  if (launcher) setenv("MM_LIBCAMERA_WORKER_LAUNCHER", saved.c_str(), 1);
}

}  // namespace
}  // namespace mm
