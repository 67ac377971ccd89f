#pragma once
// A V4L2 camera: mmap streaming of GREY, YUYV, NV12 or MJPEG, converted to BGR8 or GRAY8.
// URI: v4l2:/dev/video0?width=1280&height=720&fps=30&format=mjpeg&gray=0&exposure=..&gain=..
//
// Recovery: a device that disappears (ENODEV, EIO, POLLERR) or delivers nothing for
// `lost_after_ms` is closed and reported lost (Read returns kError once, naming the device and
// why); later Reads reopen it with exponential back-off and capture resumes, same sequence
// counter, without the caller doing anything.

#include <atomic>
#include <chrono>
#include <mutex>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "capture/frame.h"
#include "capture/pixel_format.h"
#include "capture/recovery.h"
#include "base/unique_fd.h"

namespace mm {

struct V4l2Options {
  std::string device;                 ///< e.g. /dev/video0.
  int width = 0;                      ///< 0: keep the device's current width.
  int height = 0;                     ///< 0: keep the device's current height.
  double fps = 0;                     ///< 0: keep the device's current frame rate.
  std::optional<PixelFormat> format;  ///< nullopt: the first convertible format the device offers.
  bool gray = false;                  ///< Deliver GRAY8 instead of BGR8.
  int buffers = 4;                    ///< mmap buffers requested (2..32).
  std::optional<int> exposure;        ///< Manual absolute exposure (driver units, 100 us on UVC).
  std::optional<int> gain;            ///< Manual gain (driver units).
  int lost_after_ms = 3000;           ///< No frame for this long while streaming: device lost.
  int reopen_min_ms = 100;            ///< First reopen attempt after a loss; doubles each failure.
  int reopen_max_ms = 2000;           ///< Back-off ceiling.

  /// Empty when valid, else a message naming the bad option.
  [[nodiscard]] std::string Check() const;
};

/// What a device offers, for negotiation and error messages.
struct V4l2FormatOffer {
  uint32_t fourcc = 0;
  std::string description;
  struct Size {
    int width = 0, height = 0;
    std::vector<double> fps;  ///< Discrete frame rates (empty: unknown or continuous).
  };
  std::vector<Size> sizes;  ///< Discrete sizes; empty with `stepwise` set for ranges.
  std::string stepwise;     ///< e.g. "16x16-1920x1080 step 2x2" when not discrete.
};

/// Human summary, e.g. "YUYV 640x480@15-30fps, 1280x720@10fps; MJPG 1280x720@30fps;
/// not convertible: RGB3 UYVY".
std::string DescribeOffers(const std::vector<V4l2FormatOffer>& offers);

class V4l2Source final : public FrameSource {
 public:
  explicit V4l2Source(V4l2Options options);
  ~V4l2Source() override;

  [[nodiscard]] std::string Open() override;
  [[nodiscard]] ReadStatus Read(Frame* frame, std::chrono::milliseconds timeout,
                                std::string* error) override;
  void Close() override;
  [[nodiscard]] std::string Describe() const override;

  /// Times the device was lost and reopened since Open().
  [[nodiscard]] uint64_t losses() const { return recovery_.losses(); }
  [[nodiscard]] uint64_t reopens() const { return recovery_.reopens(); }
  /// What the device offered at the last open (empty before).
  [[nodiscard]] const std::vector<V4l2FormatOffer>& offers() const { return offers_; }

 private:
  struct Buffer {
    void* addr = nullptr;
    size_t length = 0;
  };

  [[nodiscard]] std::string OpenDevice();
  void CloseDevice();
  std::string Lose(const std::string& why);
  [[nodiscard]] std::string SetControls();
  void UnmapBuffers();

  V4l2Options options_;
  UniqueFd fd_;
  std::vector<Buffer> buffers_;
  bool streaming_ = false;
  bool opened_ = false;  // Open() succeeded and Close() not yet called.
  DeviceRecovery recovery_;
  std::string last_reopen_error_;

  // Negotiated.
  PixelFormat format_ = PixelFormat::kYuyv;
  uint32_t fourcc_ = 0;
  int width_ = 0, height_ = 0;
  size_t stride_ = 0;
  double fps_ = 0;
  std::vector<V4l2FormatOffer> offers_;
  std::string card_;

  MjpegDecoder decoder_;
  uint64_t sequence_ = 0;
  mutable std::mutex describe_mutex_;
  std::string description_;  // Guarded by describe_mutex_.
};

}  // namespace mm
