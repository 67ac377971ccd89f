#pragma once
// A libcamera camera (libcamera 0.0.3, Debian 12): one viewfinder stream, frames converted to
// BGR8 or GRAY8. URI: libcamera:<camera id or index>?width=&height=&format=&gray=&timeout_ms=
//
// Recovery as V4l2Source: the camera disconnected (libcamera's signal) or silent for
// `lost_after_ms` is torn down and reported lost once; later Reads look it up again by id with
// back-off and capture resumes.

#include <chrono>
#include <condition_variable>
#include <deque>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "capture/frame.h"
#include "capture/pixel_format.h"
#include "capture/recovery.h"

namespace libcamera {
class Camera;
class CameraManager;
class FrameBufferAllocator;
class Request;
class Stream;
}  // namespace libcamera

namespace mm {

struct LibcameraOptions {
  std::string camera;                 ///< Camera id, or an index into the list ("0").
  int width = 0, height = 0;          ///< 0: the pipeline's default size.
  std::optional<PixelFormat> format;  ///< nullopt: a convertible format the stream offers.
  bool gray = false;
  int lost_after_ms = 3000;
  int reopen_min_ms = 100, reopen_max_ms = 2000;
};

/// The ids of the cameras libcamera lists on this machine (starts a CameraManager briefly).
std::vector<std::string> ListLibcameraCameras(std::string* error);

class LibcameraSource final : public FrameSource {
 public:
  explicit LibcameraSource(LibcameraOptions options);
  ~LibcameraSource() override;

  std::string Open() override;
  ReadStatus Read(Frame* frame, std::chrono::milliseconds timeout, std::string* error) override;
  void Close() override;
  [[nodiscard]] std::string Describe() const override;

  [[nodiscard]] uint64_t losses() const { return recovery_.losses(); }
  [[nodiscard]] uint64_t reopens() const { return recovery_.reopens(); }

 private:
  struct Mapping {
    void* addr = nullptr;
    size_t length = 0;
  };
  std::string OpenCamera();
  void CloseCamera();
  std::string Lose(const std::string& why);
  void OnRequestCompleted(libcamera::Request* request);
  void OnDisconnected();

  LibcameraOptions options_;
  std::shared_ptr<libcamera::CameraManager> manager_;
  std::shared_ptr<libcamera::Camera> camera_;
  std::unique_ptr<libcamera::FrameBufferAllocator> allocator_;
  std::vector<std::unique_ptr<libcamera::Request>> requests_;
  std::vector<Mapping> mappings_;  // One per buffer (planes of one buffer share the mapping).
  libcamera::Stream* stream_ = nullptr;
  bool started_ = false, acquired_ = false, opened_ = false;
  std::string id_;

  std::mutex mutex_;
  std::condition_variable cv_;
  std::deque<libcamera::Request*> completed_;  // Guarded by mutex_.
  bool disconnected_ = false;                  // Guarded by mutex_.

  PixelFormat format_ = PixelFormat::kYuyv;
  int width_ = 0, height_ = 0;
  size_t stride_ = 0;
  MjpegDecoder decoder_;
  uint64_t sequence_ = 0;
  DeviceRecovery recovery_;
  mutable std::mutex describe_mutex_;
  std::string description_;
};

}  // namespace mm
