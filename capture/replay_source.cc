#include "capture/replay_source.h"

#include <time.h>
#include <charconv>
#include <filesystem>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <thread>

#include "capture/source_uri.h"

namespace mm {

std::string ReplayOptions::Check() const {
  if (!(speed >= kMinReplaySpeed && speed <= kMaxReplaySpeed)) {
    return "speed: must be in " + std::to_string(kMinReplaySpeed) + ".." +
           std::to_string(kMaxReplaySpeed);
  }
  if (list.empty()) return "list: must name a file";
  return {};
}

ReplaySource::ReplaySource(std::filesystem::path folder, ReplayOptions options)
    : folder_(std::move(folder)), options_(std::move(options)) {}

std::string ReplaySource::Open() {
  if (std::string problem = options_.Check(); !problem.empty()) {
    return "replay:" + folder_.string() + ": " + problem;
  }
  const std::filesystem::path list = folder_ / options_.list;
  try {
    frames_ = ReadTumList(list);
  } catch (const DatasetError& e) {
    return std::string("replay: ") + e.what();
  }
  if (std::string problem = CheckTimeOrder(frames_, kMaxReplayGapS, list.string());
      !problem.empty()) {
    frames_.clear();
    return "replay: " + problem;
  }
  next_ = 0;
  sequence_ = 0;
  pass_offset_s_ = 0.0;
  decoded_.assign(options_.loop && options_.realtime ? frames_.size() : 0, cv::Mat());
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
    pass_offset_s_ +=
        span + (frames_.size() > 1 ? span / static_cast<double>(frames_.size() - 1) : 1.0);
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
  cv::Mat image = decoded_.empty() ? cv::Mat() : decoded_[next_];
  if (image.empty()) {
    image = cv::imread(item.path.string(), options_.gray ? cv::IMREAD_GRAYSCALE : cv::IMREAD_COLOR);
    if (image.empty()) {
      *error = "replay: cannot decode image " + item.path.string();
      ++next_;  // Skip it: a corrupt file must not stall the stream.
      return ReadStatus::kError;
    }
    if (options_.width > 0 && (image.cols != options_.width || image.rows != options_.height)) {
      cv::resize(image, image, cv::Size(options_.width, options_.height), 0, 0, cv::INTER_LINEAR);
    }
    if (!decoded_.empty()) {
      if (image.total() * image.elemSize() * frames_.size() <= kReplayLoopCacheBytes) {
        decoded_[next_] = image;
      } else {
        decoded_ = {};  // For good: the loop does not fit.
      }
    }
  }
  frame->image = std::move(image);
  frame->sequence = sequence_++;
  frame->capture_time_ns = MonotonicNowNs();
  frame->source_time_s = item.timestamp_s;  // The dataset's own time, for ground truth.
  frame->source_id = item.path.string();
  ++next_;
  return ReadStatus::kFrame;
}

void ReplaySource::Close() {
  frames_.clear();
  decoded_ = {};
}

std::string ReplaySource::Describe() const {
  return "replay:" + folder_.string() + " (" + std::to_string(frames_.size()) + " frames, " +
         (options_.realtime ? "realtime x" + std::to_string(options_.speed) : "max rate") +
         (options_.loop ? ", loop" : "") + ")";
}

namespace {

std::unique_ptr<FrameSource> MakeReplaySource(const SourceUri& p, const std::string& base_dir) {
  if (p.target.empty()) throw SourceUriError("camera URI '" + p.text + "': replay needs a folder");
  ReplayOptions options;
  for (const auto& [key, value] : p.params) {
    if (key == "rate") {
      if (value != "realtime" && value != "max") {
        throw SourceUriError("camera URI '" + p.text + "': rate=" + value +
                             " (expected realtime or max)");
      }
      options.realtime = value == "realtime";
    } else if (key == "speed") {
      options.speed = UriNumber<double>(p, key, value, kMinReplaySpeed, kMaxReplaySpeed);
    } else if (key == "loop") {
      options.loop = UriBool(p, key, value);
    } else if (key == "gray") {
      options.gray = UriBool(p, key, value);
    } else if (key == "list") {
      options.list = value;
    } else if (key == "width" || key == "height") {
      (key == "width" ? options.width : options.height) = UriNumber<int>(p, key, value, 1, 16384);
    } else {
      throw SourceUriError("camera URI '" + p.text + "': unknown parameter '" + key +
                           "' (replay takes rate, speed, loop, gray, list, width, height)");
    }
  }
  if ((options.width > 0) != (options.height > 0)) {
    throw SourceUriError("camera URI '" + p.text + "': give both width and height, or neither");
  }
  std::filesystem::path folder(p.target);
  if (folder.is_relative()) folder = std::filesystem::path(base_dir) / folder;
  return std::make_unique<ReplaySource>(folder.lexically_normal(), options);
}

}  // namespace

MM_REGISTER_FRAME_SOURCE(replay, MakeReplaySource);

}  // namespace mm
