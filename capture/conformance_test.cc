// Conformance of every FrameSource that is present, in the spirit of libcamera's lc-compliance:
// the same contract checks against the replay camera (always) and, with --devices, against
// each V4L2 capture device found (/dev/video*) plus the URIs in $MM_CAPTURE_URIS
// (';'-separated). With --devices and nothing found it exits 77 (skipped).

#include <glob.h>
#include <gtest/gtest.h>

#include <cstdlib>
#include <cstring>
#include <sstream>

#include "capture/capture_thread.h"
#include "capture/source_uri.h"
#include "capture/v4l2_source.h"
#include <iostream>

namespace mm {
namespace {

std::vector<std::string>& Uris() {
  static std::vector<std::string> uris;
  return uris;
}

class Conformance : public ::testing::TestWithParam<std::string> {
 protected:
  void SetUp() override {
    source_ = CreateFrameSource(GetParam(), MM_SOURCE_DIR);
    const std::string e = source_->Open();
    if (!e.empty() && e.find("busy") != std::string::npos) GTEST_SKIP() << e;
    ASSERT_EQ(e, "") << GetParam();
  }
  std::vector<Frame> ReadFrames(int n) {
    std::vector<Frame> frames;
    for (int tries = 0; static_cast<int>(frames.size()) < n && tries < 50; ++tries) {
      Frame f;
      std::string error;
      const ReadStatus s = source_->Read(&f, std::chrono::milliseconds(1000), &error);
      EXPECT_NE(s, ReadStatus::kError) << error;
      if (s == ReadStatus::kFrame) frames.push_back(std::move(f));
      if (s == ReadStatus::kEndOfStream || s == ReadStatus::kError) break;
    }
    return frames;
  }
  std::unique_ptr<FrameSource> source_;
};

TEST_P(Conformance, FramesHaveGaplessSequencesMonotonicTimesAndOneSize) {
  EXPECT_FALSE(source_->Describe().empty());
  const int64_t before = MonotonicNowNs();
  const auto frames = ReadFrames(4);
  ASSERT_EQ(frames.size(), 4u) << source_->Describe();
  for (size_t i = 0; i < frames.size(); ++i) {
    const Frame& f = frames[i];
    EXPECT_EQ(f.sequence, i);
    EXPECT_FALSE(f.image.empty());
    EXPECT_TRUE(f.image.type() == CV_8UC3 || f.image.type() == CV_8UC1);
    EXPECT_EQ(f.image.size(), frames[0].image.size());
    EXPECT_FALSE(f.source_id.empty());
    // CLOCK_MONOTONIC, not wall time; a driver timestamp may precede the Read() call a little.
    EXPECT_GT(f.capture_time_ns, before - 5'000'000'000LL);
    EXPECT_LE(f.capture_time_ns, MonotonicNowNs());
    if (i > 0) {
      EXPECT_GE(f.capture_time_ns, frames[i - 1].capture_time_ns);
    }
  }
}

TEST_P(Conformance, CloseAndReopenDeliversAgain) {
  ASSERT_EQ(ReadFrames(1).size(), 1u);
  source_->Close();
  ASSERT_EQ(source_->Open(), "");
  EXPECT_EQ(ReadFrames(2).size(), 2u);
}

TEST_P(Conformance, CaptureThreadPublishesNewestFrames) {
  source_->Close();
  CaptureThread thread(std::move(source_), {});
  ASSERT_EQ(thread.Start(), "");
  FramePtr a = thread.WaitNewer(-1, std::chrono::seconds(10));
  ASSERT_TRUE(a);
  FramePtr b = thread.WaitNewer(static_cast<int64_t>(a->sequence), std::chrono::seconds(10));
  ASSERT_TRUE(b);
  EXPECT_GT(b->sequence, a->sequence);
  thread.Stop();
}

INSTANTIATE_TEST_SUITE_P(Present, Conformance, ::testing::ValuesIn(Uris()),
                         [](const ::testing::TestParamInfo<std::string>& param_info) {
                           std::string n;
                           for (char c : param_info.param) n += std::isalnum(static_cast<unsigned char>(c)) ? c : '_';
                           return n.substr(0, 60);
                         });
GTEST_ALLOW_UNINSTANTIATED_PARAMETERIZED_TEST(Conformance);

}  // namespace
}  // namespace mm

int main(int argc, char** argv) {
  const bool devices = argc > 1 && std::strcmp(argv[1], "--devices") == 0;
  auto& uris = mm::Uris();
  if (!devices) {
    uris.push_back("replay:data/tum_office?rate=max&loop=1");
    uris.push_back("replay:data/tum_office?rate=realtime&speed=20&gray=1&loop=1");
  } else {
    glob_t g{};
    if (glob("/dev/video*", 0, nullptr, &g) == 0) {
      for (size_t i = 0; i < g.gl_pathc; ++i) {
        // Only devices that open as capture devices; others (outputs, metadata) are not cameras.
        mm::V4l2Options o;
        o.device = g.gl_pathv[i];
        mm::V4l2Source probe(o);
        if (probe.Open().empty()) uris.push_back(std::string("v4l2:") + g.gl_pathv[i]);
      }
      globfree(&g);
    }
    if (const char* env = std::getenv("MM_CAPTURE_URIS")) {
      std::stringstream ss(env);
      for (std::string u; std::getline(ss, u, ';');) {
        if (!u.empty()) uris.push_back(u);
      }
    }
    if (uris.empty()) {
      std::cerr << "SKIP: no camera present (no capturing /dev/video*, MM_CAPTURE_URIS unset)\n";
      return 77;
    }
  }
  // After the list is known: gtest evaluates ValuesIn(Uris()) when InitGoogleTest registers.
  ::testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
