#pragma once
// Writes frames into a v4l2loopback device (the OUTPUT side) with write(), so that any V4L2
// program reading the device sees them as a camera. Used by `monomesh feed` and the kernel tests.

#include <string>

#include <opencv2/core.hpp>

#include "capture/pixel_format.h"
#include "base/unique_fd.h"

namespace mm {

/// The bytes a BGR8 frame becomes on the wire in `format` (GREY: BT.601 luma as
/// cv::COLOR_BGR2GRAY; YUYV: BgrToYuyv). Only GREY and YUYV are supported for feeding.
std::string EncodeForFeed(const cv::Mat& bgr, PixelFormat format, std::string* bytes);

class LoopbackFeeder {
 public:
  LoopbackFeeder() = default;
  ~LoopbackFeeder() = default;
  LoopbackFeeder(LoopbackFeeder&&) = default;
  LoopbackFeeder& operator=(LoopbackFeeder&&) = default;

  /// Opens `device` for writing and sets its format. Returns an error naming the device.
  std::string Open(const std::string& device, int width, int height, PixelFormat format,
                   double fps);
  /// Writes one BGR8 frame (converted to the format). Returns an error message or "".
  [[nodiscard]] std::string Write(const cv::Mat& bgr);
  /// Writes already encoded bytes (exactly one frame).
  [[nodiscard]] std::string WriteRaw(const std::string& bytes);
  void Close() { fd_.reset(); }

 private:
  std::string device_;
  UniqueFd fd_;
  int width_ = 0, height_ = 0;
  PixelFormat format_ = PixelFormat::kGrey;
  std::string scratch_;
};

}  // namespace mm
