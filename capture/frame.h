#pragma once
// A captured frame and the interface every camera implements.

#include <chrono>
#include <cstdint>
#include <memory>
#include <opencv2/core.hpp>
#include <string>

namespace mm {

/// One image from a camera. Immutable once published; shared as shared_ptr<const Frame>.
struct Frame {
  cv::Mat image;                ///< BGR8 (colour) or GRAY8, as the source delivers it.
  uint64_t sequence = 0;        ///< Counts frames delivered by the source, from 0, no gaps.
  int64_t capture_time_ns = 0;  ///< CLOCK_MONOTONIC when the frame was captured.
  double source_time_s = 0.0;   ///< The source's own timestamp (dataset time for replay).
  std::string source_id;        ///< Where it came from (file path, device), for reports.
};

using FramePtr = std::shared_ptr<const Frame>;

/// Result of one FrameSource::Read().
enum class ReadStatus {
  kFrame,        ///< A frame was returned.
  kTimeout,      ///< No frame within the timeout; try again.
  kEndOfStream,  ///< A finite source (replay without loop) has no more frames.
  kError,        ///< The device failed; see the message. The source may be reopened.
};

/// A camera: opened, then read frame by frame by the capture thread.
///
/// Thread-safety: thread-bound. One thread (the capture thread) calls Read(); Describe() may
/// be called from any thread.
class FrameSource {
 public:
  virtual ~FrameSource() = default;
  /// Opens the device or dataset. Returns an empty string or a message naming what failed.
  [[nodiscard]] virtual std::string Open() = 0;
  /// Blocks up to `timeout` for the next frame.
  [[nodiscard]] virtual ReadStatus Read(Frame* frame, std::chrono::milliseconds timeout,
                                        std::string* error) = 0;
  virtual void Close() = 0;
  /// A one-line human description (URI and what was negotiated).
  [[nodiscard]] virtual std::string Describe() const = 0;
};

/// CLOCK_MONOTONIC now, nanoseconds.
int64_t MonotonicNowNs();

}  // namespace mm
