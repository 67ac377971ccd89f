#pragma once
// The capture thread: reads a FrameSource as fast as it delivers and publishes each frame into
// a newest-frame slot. It never blocks on consumers; a frame nobody took before the next one
// arrived is counted as dropped. Consumers wait for a frame newer than the one they have.
//
// Thread-safety: thread-safe (all public methods may be called from any thread).

#include <atomic>
#include <condition_variable>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <thread>

#include "capture/frame.h"
#include "capture/frame_rate.h"

namespace mm {

struct CaptureStats {
  uint64_t frames = 0;      ///< Frames published.
  uint64_t dropped = 0;     ///< Frames replaced before any consumer took them.
  uint64_t errors = 0;      ///< Read errors (each also logged through the error callback).
  bool end_of_stream = false;
  std::string last_error;
  double frame_rate_hz = 0.0;  ///< Frames published per second, lately (FrameRateMeter).
};

class CaptureThread {
 public:
  /// Called on the capture thread for every published frame (keep it short: e.g. write an
  /// eventfd) and for every error.
  struct Callbacks {
    std::function<void()> on_frame;
    std::function<void(const std::string&)> on_error;
  };

  CaptureThread(std::unique_ptr<FrameSource> source, Callbacks callbacks);
  ~CaptureThread();
  CaptureThread(const CaptureThread&) = delete;
  CaptureThread& operator=(const CaptureThread&) = delete;

  /// Opens the source and starts the thread. Returns an empty string or the open error.
  [[nodiscard]] std::string Start();
  void Stop();

  /// The newest frame, or null before the first one.
  [[nodiscard]] FramePtr Latest();
  /// Waits up to `timeout` for a frame with sequence > `after_sequence` (or any frame when
  /// `after_sequence` is negative). Null on timeout or end of stream.
  [[nodiscard]] FramePtr WaitNewer(int64_t after_sequence, std::chrono::milliseconds timeout);

  [[nodiscard]] CaptureStats stats();
  [[nodiscard]] std::string Describe() const { return source_->Describe(); }

 private:
  void Run();

  std::unique_ptr<FrameSource> source_;
  Callbacks callbacks_;
  std::thread thread_;
  std::atomic<bool> stop_{false};

  std::mutex mutex_;
  std::condition_variable cv_;
  FramePtr latest_;          // Guarded by mutex_.
  bool latest_taken_ = true;  // Guarded by mutex_.
  CaptureStats stats_;       // Guarded by mutex_.
  FrameRateMeter rate_;      // Guarded by mutex_.
};

}  // namespace mm
