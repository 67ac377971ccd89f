// The `test:` source through the registry: frames paced and numbered, the pan moves, bad
// parameters named, and the registered schemes listed.
#include "capture/test_pattern_source.h"

#include <gtest/gtest.h>

#include <algorithm>

#include "capture/source_uri.h"

namespace mm {
namespace {

using namespace std::chrono_literals;

TEST(TestPatternSource, DeliversNumberedFramesAndEnds) {
  auto source = CreateFrameSource("test:pan?width=64&height=48&fps=200&frames=3");
  ASSERT_EQ(source->Open(), "");
  Frame f[3];
  std::string error;
  for (int i = 0; i < 3; ++i) {
    ASSERT_EQ(source->Read(&f[i], 1000ms, &error), ReadStatus::kFrame) << error;
    EXPECT_EQ(f[i].sequence, static_cast<uint64_t>(i));
    EXPECT_EQ(f[i].image.size(), cv::Size(64, 48));
    EXPECT_EQ(f[i].image.type(), CV_8UC3);
    EXPECT_DOUBLE_EQ(f[i].source_time_s, i / 200.0);
  }
  Frame end;
  EXPECT_EQ(source->Read(&end, 1000ms, &error), ReadStatus::kEndOfStream);
  // One pixel of pan per frame.
  EXPECT_EQ(cv::norm(f[1].image(cv::Rect(0, 0, 63, 48)), f[0].image(cv::Rect(1, 0, 63, 48)),
                     cv::NORM_INF),
            0.0);
  EXPECT_GT(cv::norm(f[0].image, f[1].image, cv::NORM_INF), 0.0);
}

TEST(TestPatternSource, StillIsStillAndGrayIsGray) {
  auto source = CreateFrameSource("test:still?width=32&height=32&fps=500&gray=1");
  ASSERT_EQ(source->Open(), "");
  Frame a, b;
  std::string error;
  ASSERT_EQ(source->Read(&a, 1000ms, &error), ReadStatus::kFrame);
  ASSERT_EQ(source->Read(&b, 1000ms, &error), ReadStatus::kFrame);
  EXPECT_EQ(a.image.type(), CV_8UC1);
  EXPECT_EQ(cv::norm(a.image, b.image, cv::NORM_INF), 0.0);
}

TEST(TestPatternSource, SlowRateTimesOut) {
  auto source = CreateFrameSource("test:still?fps=0.5");
  ASSERT_EQ(source->Open(), "");
  Frame f;
  std::string error;
  ASSERT_EQ(source->Read(&f, 10ms, &error), ReadStatus::kFrame);  // Frame 0 is due at once.
  EXPECT_EQ(source->Read(&f, 10ms, &error), ReadStatus::kTimeout);
}

TEST(FrameSourceRegistry, ListsEverySchemeAndNamesBadParameters) {
  const std::vector<std::string> schemes = FrameSourceSchemes();
  for (const char* s : {"libcamera", "replay", "test", "v4l2"}) {
    EXPECT_NE(std::find(schemes.begin(), schemes.end(), s), schemes.end()) << s;
  }
  EXPECT_THROW(CreateFrameSource("test:plaid"), SourceUriError);
  EXPECT_THROW(CreateFrameSource("test:still?width=2"), SourceUriError);
  EXPECT_THROW(CreateFrameSource("test:still?colour=1"), SourceUriError);
  EXPECT_THROW((void)RegisterFrameSource("test", nullptr), std::logic_error);
}

}  // namespace
}  // namespace mm
