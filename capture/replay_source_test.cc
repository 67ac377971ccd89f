#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <opencv2/imgcodecs.hpp>

#include "capture/capture_thread.h"
#include "capture/replay_source.h"
#include "capture/source_uri.h"

namespace mm {
namespace {

using namespace std::chrono_literals;

// A TUM-style folder of `n` 32x24 frames whose pixel value is the frame index, 50 ms apart.
std::filesystem::path MakeDataset(const std::string& name, int n) {
  const auto dir = std::filesystem::temp_directory_path() / ("mm_replay_" + name);
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir / "rgb");
  std::ofstream list(dir / "rgb.txt");
  list << "# timestamp filename\n";
  for (int i = 0; i < n; ++i) {
    const std::string file = "rgb/" + std::to_string(i) + ".png";
    cv::imwrite((dir / file).string(), cv::Mat(24, 32, CV_8UC3, cv::Scalar(i, i, i)));
    list << 100.0 + 0.05 * i << " " << file << "\n";
  }
  return dir;
}

TEST(ReplaySource, DeliversFramesInOrderThenEnds) {
  const auto dir = MakeDataset("order", 4);
  ReplayOptions options;
  options.realtime = false;
  ReplaySource source(dir, options);
  ASSERT_EQ(source.Open(), "");
  std::string error;
  for (int i = 0; i < 4; ++i) {
    Frame frame;
    ASSERT_EQ(source.Read(&frame, 100ms, &error), ReadStatus::kFrame) << error;
    EXPECT_EQ(frame.sequence, static_cast<uint64_t>(i));
    EXPECT_EQ(frame.image.at<cv::Vec3b>(0, 0)[0], i);
    EXPECT_NEAR(frame.source_time_s, 100.0 + 0.05 * i, 1e-9);
  }
  Frame frame;
  EXPECT_EQ(source.Read(&frame, 100ms, &error), ReadStatus::kEndOfStream);
}

TEST(ReplaySource, LoopsWithIncreasingSequence) {
  const auto dir = MakeDataset("loop", 2);
  ReplayOptions options;
  options.realtime = false;
  options.loop = true;
  options.gray = true;
  ReplaySource source(dir, options);
  ASSERT_EQ(source.Open(), "");
  std::string error;
  for (int i = 0; i < 5; ++i) {
    Frame frame;
    ASSERT_EQ(source.Read(&frame, 100ms, &error), ReadStatus::kFrame);
    EXPECT_EQ(frame.sequence, static_cast<uint64_t>(i));
    EXPECT_EQ(frame.image.type(), CV_8UC1);
    EXPECT_EQ(frame.image.at<uint8_t>(0, 0), i % 2);
  }
}

// Plays the first pass of `n` frames, then removes the files: the next read either comes from
// what the first pass decoded or fails naming the file.
ReadStatus ReadAfterFirstPassWithoutFiles(const std::filesystem::path& dir, int n,
                                          const ReplayOptions& options, Frame* frame,
                                          std::string* error) {
  ReplaySource source(dir, options);
  EXPECT_EQ(source.Open(), "");
  for (int i = 0; i < n; ++i) {
    Frame first;
    EXPECT_EQ(source.Read(&first, 100ms, error), ReadStatus::kFrame) << *error;
  }
  std::filesystem::remove_all(dir / "rgb");
  return source.Read(frame, 100ms, error);
}

// A loop at its recorded rate that fits kReplayLoopCacheBytes decodes each file once: its
// later passes play on with the files gone. One that does not fit, or at the maximum rate,
// reads the files again on every pass.
TEST(ReplaySource, LoopDecodesEachFileOnceWhenItsFramesFitTheCache) {
  ReplayOptions options;
  options.speed = 100.0;
  options.loop = true;
  Frame frame;
  std::string error;
  ASSERT_EQ(ReadAfterFirstPassWithoutFiles(MakeDataset("loopcache", 3), 3, options, &frame, &error),
            ReadStatus::kFrame)
      << error;
  EXPECT_EQ(frame.image.at<cv::Vec3b>(0, 0)[0], 0);
  EXPECT_EQ(frame.sequence, 3u);
}

TEST(ReplaySource, LoopTooLargeForTheCacheReadsTheFilesEachPass) {
  ReplayOptions options;
  options.speed = 100.0;
  options.loop = true;
  // Two frames of 4000x1500x3 bytes (18 MB) do not fit 16 MiB.
  options.width = 4000;
  options.height = 1500;
  ASSERT_GT(size_t{4000} * 1500 * 3 * 2, kReplayLoopCacheBytes);
  Frame frame;
  std::string error;
  EXPECT_EQ(
      ReadAfterFirstPassWithoutFiles(MakeDataset("loopnocache", 2), 2, options, &frame, &error),
      ReadStatus::kError);
  EXPECT_NE(error.find("cannot decode image"), std::string::npos) << error;
}

TEST(ReplaySource, LoopAtTheMaximumRateReadsTheFilesEachPass) {
  ReplayOptions options;
  options.realtime = false;
  options.loop = true;
  Frame frame;
  std::string error;
  EXPECT_EQ(ReadAfterFirstPassWithoutFiles(MakeDataset("loopmax", 2), 2, options, &frame, &error),
            ReadStatus::kError);
}

TEST(ReplaySource, ResizesToTheRequestedSize) {
  const auto dir = MakeDataset("resize", 1);
  ReplayOptions options;
  options.realtime = false;
  options.width = 64;
  options.height = 36;
  ReplaySource source(dir, options);
  ASSERT_EQ(source.Open(), "");
  std::string error;
  Frame frame;
  ASSERT_EQ(source.Read(&frame, 100ms, &error), ReadStatus::kFrame) << error;
  EXPECT_EQ(frame.image.cols, 64);
  EXPECT_EQ(frame.image.rows, 36);
}

TEST(ReplaySource, RealtimeNeverDeliversEarly) {
  const auto dir = MakeDataset("realtime", 5);
  ReplayOptions options;
  options.speed = 2.0;  // 0.2 s of dataset time -> at least 0.1 s.
  ReplaySource source(dir, options);
  ASSERT_EQ(source.Open(), "");
  const int64_t start = MonotonicNowNs();
  std::string error;
  int frames = 0;
  while (frames < 5) {
    Frame frame;
    const ReadStatus s = source.Read(&frame, 20ms, &error);
    if (s == ReadStatus::kFrame) ++frames;
    ASSERT_NE(s, ReadStatus::kError) << error;
  }
  EXPECT_GE(MonotonicNowNs() - start, 100'000'000);
}

TEST(ReplaySource, CorruptImageIsAnErrorNamingTheFileAndIsSkipped) {
  const auto dir = MakeDataset("corrupt", 3);
  std::ofstream(dir / "rgb/1.png") << "not a png";
  ReplayOptions options;
  options.realtime = false;
  ReplaySource source(dir, options);
  ASSERT_EQ(source.Open(), "");
  std::string error;
  Frame frame;
  EXPECT_EQ(source.Read(&frame, 100ms, &error), ReadStatus::kFrame);
  EXPECT_EQ(source.Read(&frame, 100ms, &error), ReadStatus::kError);
  EXPECT_NE(error.find("rgb/1.png"), std::string::npos) << error;
  EXPECT_EQ(source.Read(&frame, 100ms, &error), ReadStatus::kFrame);
  EXPECT_EQ(frame.image.at<cv::Vec3b>(0, 0)[0], 2);
}

TEST(ReplaySource, MissingListIsAnOpenErrorNamingThePath) {
  ReplaySource source("/nonexistent/dataset", ReplayOptions{});
  const std::string error = source.Open();
  EXPECT_NE(error.find("/nonexistent/dataset/rgb.txt"), std::string::npos) << error;
}

// A list whose timestamps go back in time or jump by minutes is a broken recording: Open says
// which line, instead of pacing the replay by it (a 1e9 s jump would wait for 30 years).
TEST(ReplaySource, TimestampOutOfOrderOrFarFromItsNeighboursIsAnOpenError) {
  const auto dir = MakeDataset("timestamps", 3);
  const auto write_list = [&](const std::string& third) {
    std::ofstream(dir / "rgb.txt") << "# timestamp filename\n100.0 rgb/0.png\n100.05 rgb/1.png\n"
                                   << third << " rgb/2.png\n";
  };
  for (const char* third : {"99.0", "1e9", "161"}) {
    write_list(third);
    ReplaySource source(dir, ReplayOptions{});
    const std::string error = source.Open();
    EXPECT_NE(error.find((dir / "rgb.txt").string() + ":4: timestamp"), std::string::npos)
        << third << ": " << error;
  }
  write_list("159");  // 59 s: a pause, accepted.
  ReplaySource source(dir, ReplayOptions{});
  EXPECT_EQ(source.Open(), "");
}

TEST(SourceUri, ParsesReplayAndRejectsBadParameters) {
  EXPECT_NE(CreateFrameSource("replay:data/x?rate=max&loop=1", "/base"), nullptr);
  EXPECT_NE(CreateFrameSource("replay:data/x?rate=max", "/base")->Describe().find("/base/data/x"),
            std::string::npos);
  EXPECT_THROW(CreateFrameSource("replay:x?rate=fast"), SourceUriError);
  EXPECT_THROW(CreateFrameSource("replay:x?bogus=1"), SourceUriError);
  EXPECT_THROW(CreateFrameSource("replay:x?speed=-1"), SourceUriError);
  EXPECT_THROW(CreateFrameSource("replay:x?speed=inf"), SourceUriError);
  EXPECT_THROW(CreateFrameSource("replay:x?speed=1e-300"), SourceUriError);
  EXPECT_THROW(CreateFrameSource("replay:x?width=640"), SourceUriError);
  EXPECT_THROW(CreateFrameSource("replay:x?width=0&height=10"), SourceUriError);
  EXPECT_THROW(CreateFrameSource("nocolon"), SourceUriError);
  try {
    CreateFrameSource("tape:/dev/st0");
    FAIL();
  } catch (const SourceUriError& e) {
    EXPECT_NE(std::string(e.what()).find("unknown scheme 'tape'"), std::string::npos);
  }
}

TEST(CaptureThread, PublishesNewestFrameAndCountsDrops) {
  const auto dir = MakeDataset("thread", 20);
  ReplayOptions options;
  options.realtime = false;
  std::atomic<int> published{0};
  CaptureThread capture(std::make_unique<ReplaySource>(dir, options),
                        {.on_frame = [&] { ++published; }, .on_error = nullptr});
  ASSERT_EQ(capture.Start(), "");
  const FramePtr first = capture.WaitNewer(-1, 2s);
  ASSERT_NE(first, nullptr);
  // Nobody consumes: the source runs to its end; all but the frames taken are drops.
  for (int i = 0; i < 200 && !capture.stats().end_of_stream; ++i) std::this_thread::sleep_for(5ms);
  const CaptureStats stats = capture.stats();
  EXPECT_TRUE(stats.end_of_stream);
  EXPECT_EQ(stats.frames, 20u);
  EXPECT_EQ(published.load(), 20);
  EXPECT_GE(stats.dropped, 18u);
  const FramePtr last = capture.Latest();
  ASSERT_NE(last, nullptr);
  EXPECT_EQ(last->sequence, 19u);
  EXPECT_EQ(capture.WaitNewer(19, 50ms), nullptr);
  capture.Stop();
}

}  // namespace
}  // namespace mm
