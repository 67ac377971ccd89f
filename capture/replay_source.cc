#include "capture/replay_source.h"

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <thread>
#include <time.h>

namespace mm {

std::string ReplayOptions::Check() const {
  if (!(speed > 0.0)) return "speed: must be > 0";
  if (list.empty()) return "list: must name a file";
  return {};
}

ReplaySource::ReplaySource(std::filesystem::path folder, ReplayOptions options)
    : folder_(std::move(folder)), options_(std::move(options)) {}

std::string ReplaySource::Open() {
  if (std::string problem = options_.Check(); !problem.empty()) {
    return "replay:" + folder_.string() + ": " + problem;
  }
  try {
    frames_ = ReadTumList(folder_ / options_.list);
  } catch (const DatasetError& e) {
    return std::string("replay: ") + e.what();
  }
  next_ = 0;
  sequence_ = 0;
  pass_offset_s_ = 0.0;
  start_ns_ = MonotonicNowNs();
  return {};
}

ReadStatus ReplaySource::Read(Frame* frame, std::chrono::milliseconds timeout, std::string* error) {
  if (frames_.empty()) {
    *error = "replay:" + folder_.string() + ": not open";
    return ReadStatus::kError;
  }
  if (next_ == frames_.size()) {
    if (!options_.loop) return ReadStatus::kEndOfStream;
    // Keep dataset time increasing across passes: one mean frame interval after the last one.
    const double span = frames_.back().timestamp_s - frames_.front().timestamp_s;
    pass_offset_s_ += span + (frames_.size() > 1 ? span / static_cast<double>(frames_.size() - 1)
                                                 : 1.0);
    next_ = 0;
  }
  const TumFrame& item = frames_[next_];
  if (options_.realtime) {
    const double due_s =
        (item.timestamp_s + pass_offset_s_ - frames_.front().timestamp_s) / options_.speed;
    const int64_t due_ns = start_ns_ + static_cast<int64_t>(due_s * 1e9);
    const int64_t wait_ns = due_ns - MonotonicNowNs();
    if (wait_ns > 0) {
      const auto wait = std::chrono::nanoseconds(wait_ns);
      if (wait > timeout) {
        std::this_thread::sleep_for(timeout);
        return ReadStatus::kTimeout;
      }
      std::this_thread::sleep_for(wait);
    }
  }
  cv::Mat image = cv::imread(item.path.string(),
                             options_.gray ? cv::IMREAD_GRAYSCALE : cv::IMREAD_COLOR);
  if (image.empty()) {
    *error = "replay: cannot decode image " + item.path.string();
    ++next_;  // Skip it: a corrupt file must not stall the stream.
    return ReadStatus::kError;
  }
  if (options_.width > 0 && (image.cols != options_.width || image.rows != options_.height)) {
    cv::resize(image, image, cv::Size(options_.width, options_.height), 0, 0, cv::INTER_LINEAR);
  }
  frame->image = std::move(image);
  frame->sequence = sequence_++;
  frame->capture_time_ns = MonotonicNowNs();
  frame->source_time_s = item.timestamp_s;  // The dataset's own time, for ground truth.
  frame->source_id = item.path.string();
  ++next_;
  return ReadStatus::kFrame;
}

void ReplaySource::Close() { frames_.clear(); }

std::string ReplaySource::Describe() const {
  return "replay:" + folder_.string() + " (" + std::to_string(frames_.size()) + " frames, " +
         (options_.realtime ? "realtime x" + std::to_string(options_.speed) : "max rate") +
         (options_.loop ? ", loop" : "") + ")";
}

}  // namespace mm
