// Which frames before keyframe A are kept and handed out (pure logic on time stamps).
#include "session/recent_frames.h"

#include <gtest/gtest.h>

#include <iostream>

namespace mm {
namespace {

// A 1x1 frame carrying its time in ms, to tell frames apart.
cv::Mat Tagged(double time_s) {
  return cv::Mat(1, 1, CV_32SC1, cv::Scalar(static_cast<int>(std::lround(1000 * time_s))));
}
double TimeOf(const cv::Mat& frame) { return frame.at<int>(0, 0) / 1000.0; }

TEST(RecentFrames, KeepsFewFramesAndHandsOutOneNearEachOffset) {
  const RecentFramesOptions options;
  RecentFrames history(options);
  // 30 Hz for 10 s; A at the end.
  size_t most = 0;
  for (int i = 0; i <= 300; ++i) {
    history.Add(Tagged(i / 30.0), i / 30.0);
    most = std::max(most, history.size());
  }
  std::cout << "[ figures  ] frames kept at most: " << most << "\n";
  // Spaced by at least a quarter of their age over 3 s (measured: 9 at most), of 90 frames.
  EXPECT_LE(most, 12U);
  const double time_a = 10.0;
  const std::vector<cv::Mat> before = history.BeforeA(time_a);
  ASSERT_EQ(before.size(), options.seconds_before_a.size());
  for (size_t k = 0; k < before.size(); ++k) {
    const double offset = options.seconds_before_a[k];
    const double age = time_a - TimeOf(before[k]);
    // Gaps of at most a quarter of the age (and 1/16 s), so the nearest is within about an
    // eighth of the offset, plus one frame period.
    EXPECT_NEAR(age, offset, std::max(offset * options.age_spacing / 2, 0.04) + 1 / 30.0)
        << "offset " << offset;
    if (k > 0) {
      EXPECT_GT(age, time_a - TimeOf(before[k - 1]));  // Newest first, each once.
    }
  }
}

TEST(RecentFrames, LeavesOutOffsetsWithNoFrameNearThem) {
  const RecentFramesOptions options;
  RecentFrames history(options);
  // Frames only in the last 0.3 s before A (the camera just started): nothing for 1 s or 2 s.
  for (int i = 0; i < 9; ++i) history.Add(Tagged(10.0 + i / 30.0), 10.0 + i / 30.0);
  const double time_a = 10.3;
  const std::vector<cv::Mat> before = history.BeforeA(time_a);
  ASSERT_FALSE(before.empty());
  for (const cv::Mat& frame : before) {
    EXPECT_LT(TimeOf(frame), time_a);
    EXPECT_LT(time_a - TimeOf(frame), 0.75);  // Within half of 0.5 s, the largest offset met.
  }
  // A frame at 1 s, as at a 1 Hz keyframe list, is handed out for 1 s only (0.5 s is too far).
  RecentFrames sparse(options);
  sparse.Add(Tagged(1.0), 1.0);
  sparse.Add(Tagged(2.0), 2.0);
  const std::vector<cv::Mat> one = sparse.BeforeA(2.0);
  ASSERT_EQ(one.size(), 1U);
  EXPECT_EQ(TimeOf(one[0]), 1.0);
  // Nothing before the first frame, and A itself is never handed out.
  EXPECT_TRUE(sparse.BeforeA(1.0).empty());
}

TEST(RecentFrames, RefusesOffsetsThatDoNotAscend) {
  EXPECT_EQ(RecentFramesOptions{}.Check(), "");
  RecentFramesOptions bad;
  bad.seconds_before_a = {0.5, 0.25};
  EXPECT_NE(bad.Check(), "");
  bad = {};
  bad.spacing_s = 0;
  EXPECT_NE(bad.Check(), "");
  bad = {};
  bad.age_spacing = 1;
  EXPECT_NE(bad.Check(), "");
}

}  // namespace
}  // namespace mm
