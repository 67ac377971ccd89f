#include "capture/test_pattern_source.h"

#include <opencv2/imgproc.hpp>
#include <thread>

#include "capture/source_uri.h"

namespace mm {

TestPatternSource::TestPatternSource(TestPatternOptions options) : options_(std::move(options)) {}

std::string TestPatternSource::Open() {
  // Random 8x8 blocks, blurred a little: corners everywhere for the keyframe gate.
  cv::Mat blocks(options_.height / 4 + 1, options_.width / 4 + 1, CV_8UC3);
  cv::RNG rng(20240607);
  rng.fill(blocks, cv::RNG::UNIFORM, 0, 256);
  cv::resize(blocks, texture_, cv::Size(blocks.cols * 8, blocks.rows * 8), 0, 0, cv::INTER_NEAREST);
  cv::GaussianBlur(texture_, texture_, cv::Size(3, 3), 0);
  next_ = 0;
  start_ = std::chrono::steady_clock::now();
  return {};
}

ReadStatus TestPatternSource::Read(Frame* frame, std::chrono::milliseconds timeout,
                                   std::string* error) {
  if (texture_.empty()) {
    *error = "test pattern source is not open";
    return ReadStatus::kError;
  }
  if (options_.frames > 0 && next_ >= options_.frames) return ReadStatus::kEndOfStream;
  const auto due =
      start_ + std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                   std::chrono::duration<double>(static_cast<double>(next_) / options_.fps));
  const auto now = std::chrono::steady_clock::now();
  if (due > now + timeout) {
    std::this_thread::sleep_for(timeout);
    return ReadStatus::kTimeout;
  }
  std::this_thread::sleep_until(due);
  const int shift = options_.pattern == "pan" ? static_cast<int>(next_ % options_.width) : 0;
  cv::Mat image = texture_(cv::Rect(shift, 0, options_.width, options_.height)).clone();
  if (options_.gray) cv::cvtColor(image, image, cv::COLOR_BGR2GRAY);
  frame->image = image;
  frame->sequence = next_;
  frame->capture_time_ns = MonotonicNowNs();
  frame->source_time_s = static_cast<double>(next_) / options_.fps;
  frame->source_id = "test:" + options_.pattern + "#" + std::to_string(next_);
  ++next_;
  return ReadStatus::kFrame;
}

void TestPatternSource::Close() { texture_.release(); }

std::string TestPatternSource::Describe() const {
  return "test:" + options_.pattern + " (" + std::to_string(options_.width) + "x" +
         std::to_string(options_.height) + " at " + std::to_string(options_.fps) + " fps)";
}

namespace {

std::unique_ptr<FrameSource> MakeTestPatternSource(const SourceUri& p, const std::string&) {
  TestPatternOptions o;
  if (!p.target.empty()) o.pattern = p.target;
  if (o.pattern != "still" && o.pattern != "pan") {
    throw SourceUriError("camera URI '" + p.text + "': pattern '" + o.pattern +
                         "' (expected still or pan)");
  }
  for (const auto& [key, value] : p.params) {
    if (key == "width") {
      o.width = UriNumber<int>(p, key, value, 16, 4096);
    } else if (key == "height") {
      o.height = UriNumber<int>(p, key, value, 16, 4096);
    } else if (key == "fps") {
      o.fps = UriNumber<double>(p, key, value, 0.1, 1000.0);
    } else if (key == "frames") {
      o.frames = UriNumber<uint64_t>(p, key, value, 0, uint64_t{1} << 40);
    } else if (key == "gray") {
      o.gray = UriBool(p, key, value);
    } else {
      throw SourceUriError("camera URI '" + p.text + "': unknown parameter '" + key +
                           "' (test takes width, height, fps, frames, gray)");
    }
  }
  return std::make_unique<TestPatternSource>(o);
}

}  // namespace

MM_REGISTER_FRAME_SOURCE(test, MakeTestPatternSource);

}  // namespace mm
