#include "capture/capture_thread.h"

namespace mm {

CaptureThread::CaptureThread(std::unique_ptr<FrameSource> source, Callbacks callbacks)
    : source_(std::move(source)), callbacks_(std::move(callbacks)) {}

CaptureThread::~CaptureThread() { Stop(); }

std::string CaptureThread::Start() {
  if (std::string error = source_->Open(); !error.empty()) return error;
  stop_ = false;
  thread_ = std::thread([this] { Run(); });
  return {};
}

void CaptureThread::Stop() {
  stop_ = true;
  if (thread_.joinable()) thread_.join();
  source_->Close();
  cv_.notify_all();
}

void CaptureThread::Run() {
  using namespace std::chrono_literals;
  while (!stop_) {
    auto frame = std::make_shared<Frame>();
    std::string error;
    ReadStatus status = ReadStatus::kError;
    // An exception leaving the thread would call std::terminate: one a source throws while
    // reading (a decoder's, OpenCV's on a corrupt or huge image) is that read's error.
    try {
      status = source_->Read(frame.get(), 100ms, &error);
    } catch (const std::exception& e) {
      error = Describe() + ": " + e.what();
    } catch (...) {
      error = Describe() + ": unknown exception while reading a frame";
    }
    if (status == ReadStatus::kTimeout) continue;
    if (status == ReadStatus::kEndOfStream) {
      std::lock_guard lock(mutex_);
      stats_.end_of_stream = true;
      cv_.notify_all();
      break;
    }
    if (status == ReadStatus::kError) {
      {
        std::lock_guard lock(mutex_);
        ++stats_.errors;
        stats_.last_error = error;
      }
      if (callbacks_.on_error) callbacks_.on_error(error);
      std::this_thread::sleep_for(10ms);  // Do not spin on a failing device.
      continue;
    }
    {
      std::lock_guard lock(mutex_);
      if (!latest_taken_) ++stats_.dropped;
      latest_ = std::move(frame);
      latest_taken_ = false;
      ++stats_.frames;
      rate_.Add(FrameRateMeter::Clock::now());
    }
    cv_.notify_all();
    if (callbacks_.on_frame) callbacks_.on_frame();
  }
}

FramePtr CaptureThread::Latest() {
  std::lock_guard lock(mutex_);
  latest_taken_ = true;
  return latest_;
}

FramePtr CaptureThread::WaitNewer(int64_t after_sequence, std::chrono::milliseconds timeout) {
  std::unique_lock lock(mutex_);
  const bool ready = cv_.wait_for(lock, timeout, [&] {
    return (latest_ && static_cast<int64_t>(latest_->sequence) > after_sequence) ||
           stats_.end_of_stream || stop_;
  });
  if (!ready || !latest_ || static_cast<int64_t>(latest_->sequence) <= after_sequence) {
    return nullptr;
  }
  latest_taken_ = true;
  return latest_;
}

CaptureStats CaptureThread::stats() {
  std::lock_guard lock(mutex_);
  CaptureStats stats = stats_;
  stats.frame_rate_hz = rate_.RateHz(FrameRateMeter::Clock::now());
  return stats;
}

}  // namespace mm
