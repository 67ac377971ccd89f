#include "app/gate_thread.h"

#include <unistd.h>

namespace mm {

GateThread::GateThread(const Undistorter& undistorter, CaptureSession* session, int done_fd)
    : undistorter_(undistorter), session_(session), done_fd_(done_fd) {
  thread_ = std::thread([this] { Run(); });
}

GateThread::~GateThread() {
  {
    std::lock_guard lock(mutex_);
    stop_ = true;
  }
  cv_.notify_all();
  thread_.join();
}

bool GateThread::busy() const {
  std::lock_guard lock(mutex_);
  return posted_.has_value() || running_ || done_.has_value();
}

void GateThread::Post(uint64_t capture_id, FramePtr frame) {
  {
    std::lock_guard lock(mutex_);
    posted_.emplace();
    posted_->capture_id = capture_id;
    posted_->frame = std::move(frame);
  }
  cv_.notify_all();
}

std::optional<TrackedFrame> GateThread::Take() {
  std::lock_guard lock(mutex_);
  std::optional<TrackedFrame> out = std::move(done_);
  done_.reset();
  return out;
}

void GateThread::WaitIdle() {
  std::unique_lock lock(mutex_);
  cv_.wait(lock, [&] { return !posted_.has_value() && !running_; });
}

void GateThread::Run() {
  for (;;) {
    TrackedFrame tracked;
    {
      std::unique_lock lock(mutex_);
      cv_.wait(lock, [&] { return stop_ || posted_.has_value(); });
      if (stop_) return;
      tracked = std::move(*posted_);
      posted_.reset();
      running_ = true;
    }
    try {
      tracked.undistorted = undistorter_.Apply(tracked.frame->image);
      tracked.decision = session_->Track(ToGray(tracked.undistorted));
    } catch (const std::exception& e) {
      // A frame that does not fit the calibration (cv::Exception), or the gate failing on it:
      // the loop ends the capture with this error; the thread serves the next one.
      tracked.error = e.what();
    }
    {
      std::lock_guard lock(mutex_);
      running_ = false;
      done_ = std::move(tracked);
    }
    cv_.notify_all();
    const uint64_t one = 1;
    [[maybe_unused]] const ssize_t n = ::write(done_fd_, &one, sizeof(one));
  }
}

}  // namespace mm
