// mm-libcamera-worker: libcamera 0.0.3 in its own process, driven by LibcameraSource over the
// socket on fd 3 (capture/libcamera_ipc.h says why and how).
//
//   mm-libcamera-worker --list
//   mm-libcamera-worker --camera ID|INDEX [--width W --height H] [--format NAME]
//
// Streaming: acquire and configure one viewfinder stream, send the buffers' dmabufs, start,
// then send a FrameReady per completed request and requeue the buffers the parent returns.
// Exits 0 after kStop or when the parent goes away; exits at once (no Camera::stop(), which
// aborts in 0.0.3 when the device is gone) when libcamera reports the camera disconnected.

#include <fcntl.h>
#include <poll.h>
#include <unistd.h>

#include <libcamera/libcamera.h>
#include <algorithm>
#include <charconv>
#include <cstdio>
#include <cstring>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "capture/libcamera_ipc.h"
#include "capture/pixel_format.h"

namespace mm {
namespace {

using lcipc::MsgType;

std::optional<PixelFormat> FromLibcamera(const libcamera::PixelFormat& f) {
  if (f == libcamera::formats::YUYV) return PixelFormat::kYuyv;
  if (f == libcamera::formats::NV12) return PixelFormat::kNv12;
  if (f == libcamera::formats::R8) return PixelFormat::kGrey;
  if (f == libcamera::formats::MJPEG) return PixelFormat::kMjpeg;
  if (f == libcamera::formats::RGB888) return PixelFormat::kBgr24;  // DRM order: bytes B,G,R.
  if (f == libcamera::formats::BGR888) return PixelFormat::kRgb24;
  return std::nullopt;
}

int SendText(MsgType type, const std::string& text) {
  lcipc::Text m;
  m.type = type;
  lcipc::SetText(m.text, text);
  lcipc::Send(lcipc::kSocketFd, &m, sizeof(m));
  return type == MsgType::kError ? 1 : 0;
}

struct Args {
  bool list = false;
  std::string camera;
  int width = 0, height = 0;
  std::optional<PixelFormat> format;
};

/// Streams one camera until told to stop; every resource is released by the destructors in
/// reverse order (requests, allocator, camera, manager).
class Worker {
 public:
  explicit Worker(Args args) : args_(std::move(args)) {}
  ~Worker() {
    if (camera_) {
      camera_->requestCompleted.disconnect(this);
      camera_->disconnected.disconnect(this);
      if (started_) camera_->stop();
      requests_.clear();
      if (allocator_ && stream_) allocator_->free(stream_);
      allocator_.reset();
      if (acquired_) camera_->release();
      camera_.reset();
    }
    if (manager_) manager_->stop();
  }
  Worker(const Worker&) = delete;
  Worker& operator=(const Worker&) = delete;

  int Run() {
    manager_ = std::make_unique<libcamera::CameraManager>();
    if (const int r = manager_->start(); r != 0) {
      manager_.reset();
      return SendText(MsgType::kError, "CameraManager::start: " + std::string(strerror(-r)));
    }
    const auto cameras = manager_->cameras();
    if (args_.list) {
      std::string ids;
      for (const auto& c : cameras) ids += c->id() + "\n";
      return SendText(MsgType::kCameras, ids);
    }
    std::string listed;
    for (size_t i = 0; i < cameras.size(); ++i) {
      listed += (i ? ", " : "") + std::to_string(i) + "='" + cameras[i]->id() + "'";
    }
    if (listed.empty()) listed = "none";
    camera_ = manager_->get(args_.camera);
    size_t index = 0;
    const std::string& want = args_.camera;
    const auto r = std::from_chars(want.data(), want.data() + want.size(), index);
    if (!camera_ && r.ec == std::errc() && r.ptr == want.data() + want.size() &&
        index < cameras.size()) {
      camera_ = cameras[index];
    }
    if (!camera_)
      return SendText(MsgType::kError, "no such camera (libcamera lists: " + listed + ")");
    if (camera_->acquire() != 0) {
      camera_.reset();
      return SendText(MsgType::kError, "camera busy (acquired by another process)");
    }
    acquired_ = true;
    camera_->disconnected.connect(this, &Worker::OnDisconnected);
    if (std::string e = Configure(); !e.empty()) return SendText(MsgType::kError, e);
    camera_->requestCompleted.connect(this, &Worker::OnRequestCompleted);
    if (camera_->start() != 0) return SendText(MsgType::kError, "Camera::start failed");
    started_ = true;
    for (auto& request : requests_) camera_->queueRequest(request.get());
    return Serve();
  }

 private:
  std::string Configure() {
    std::unique_ptr<libcamera::CameraConfiguration> config =
        camera_->generateConfiguration({libcamera::StreamRole::Viewfinder});
    if (!config || config->empty()) return "no viewfinder configuration";
    libcamera::StreamConfiguration& sc = config->at(0);
    std::string offered;
    std::optional<libcamera::PixelFormat> chosen;
    for (const libcamera::PixelFormat& f : sc.formats().pixelformats()) {
      offered += (offered.empty() ? "" : " ") + f.toString();
      const auto ours = FromLibcamera(f);
      if (!ours) continue;
      if (args_.format ? *ours == *args_.format : !chosen) chosen = f;
    }
    if (!chosen && FromLibcamera(sc.pixelFormat) && !args_.format) chosen = sc.pixelFormat;
    if (!chosen) {
      return (args_.format ? "format " + PixelFormatName(*args_.format) + " not offered"
                           : std::string("no format this build converts")) +
             "; the stream offers: " + offered;
    }
    sc.pixelFormat = *chosen;
    if (args_.width > 0) sc.size = libcamera::Size(args_.width, args_.height);
    sc.bufferCount = std::clamp(sc.bufferCount, 4u, lcipc::kMaxBuffers);
    if (config->validate() == libcamera::CameraConfiguration::Invalid) {
      return "configuration invalid; the stream offers: " + offered;
    }
    if (sc.pixelFormat != *chosen ||
        (args_.width > 0 && (static_cast<int>(sc.size.width) != args_.width ||
                             static_cast<int>(sc.size.height) != args_.height))) {
      return "asked for " + chosen->toString() + " " + std::to_string(args_.width) + "x" +
             std::to_string(args_.height) + ", the pipeline adjusted it to " + sc.toString() +
             "; the stream offers: " + offered;
    }
    if (camera_->configure(config.get()) != 0) return "Camera::configure failed";
    stream_ = sc.stream();
    allocator_ = std::make_unique<libcamera::FrameBufferAllocator>(camera_);
    if (allocator_->allocate(stream_) < 0) return "cannot allocate buffers";
    const auto& buffers = allocator_->buffers(stream_);
    if (buffers.size() > lcipc::kMaxBuffers) return "more buffers than the worker can pass";
    lcipc::Configured m;
    m.format = static_cast<int32_t>(*FromLibcamera(sc.pixelFormat));
    m.width = static_cast<int32_t>(sc.size.width);
    m.height = static_cast<int32_t>(sc.size.height);
    m.stride = sc.stride;
    m.buffers = static_cast<uint32_t>(buffers.size());
    lcipc::SetText(m.id, camera_->id());
    lcipc::SetText(m.description, sc.toString());
    std::vector<int> fds;
    for (size_t i = 0; i < buffers.size(); ++i) {
      const libcamera::FrameBuffer& buffer = *buffers[i];
      const int fd = buffer.planes()[0].fd.get();
      size_t length = 0;
      for (const auto& plane : buffer.planes()) {
        if (plane.fd.get() != fd) return "a frame buffer spans several dmabufs (not supported)";
        length = std::max<size_t>(length, plane.offset + plane.length);
      }
      m.offset[i] = buffer.planes()[0].offset;
      m.length[i] = length;
      fds.push_back(fd);
      std::unique_ptr<libcamera::Request> request = camera_->createRequest(i);
      if (!request || request->addBuffer(stream_, buffers[i].get()) != 0)
        return "cannot create a request";
      requests_.push_back(std::move(request));
    }
    if (!lcipc::Send(lcipc::kSocketFd, &m, sizeof(m), fds)) return "parent gone";
    return {};
  }

  // libcamera's thread: hand the buffer to the parent (it owns it until kRequeue).
  void OnRequestCompleted(libcamera::Request* request) {
    if (request->status() == libcamera::Request::RequestCancelled) return;
    const libcamera::FrameBuffer* buffer = request->findBuffer(stream_);
    const libcamera::FrameMetadata& md = buffer->metadata();
    lcipc::FrameReady m;
    m.index = static_cast<uint32_t>(request->cookie());
    m.ok = md.status == libcamera::FrameMetadata::FrameSuccess ? 1 : 0;
    for (const auto& p : md.planes()) m.bytesused += p.bytesused;
    m.timestamp_ns = md.timestamp;
    std::lock_guard lock(send_mutex_);
    lcipc::Send(lcipc::kSocketFd, &m, sizeof(m));
  }

  void OnDisconnected() {
    {
      std::lock_guard lock(send_mutex_);
      lcipc::Command m{MsgType::kDisconnected, 0};
      lcipc::Send(lcipc::kSocketFd, &m, sizeof(m));
    }
    std::fflush(stderr);
    _exit(3);  // Camera::stop() on a vanished device aborts in libcamera 0.0.3.
  }

  int Serve() {
    for (;;) {
      lcipc::Command c;
      const long n = lcipc::Receive(lcipc::kSocketFd, &c, sizeof(c));
      if (n <= 0) return 0;  // The parent went away.
      if (c.type == MsgType::kStop) return 0;
      if (c.type == MsgType::kRequeue && c.index < requests_.size()) {
        libcamera::Request* request = requests_[c.index].get();
        request->reuse(libcamera::Request::ReuseBuffers);
        camera_->queueRequest(request);
      }
    }
  }

  Args args_;
  std::unique_ptr<libcamera::CameraManager> manager_;
  std::shared_ptr<libcamera::Camera> camera_;
  std::unique_ptr<libcamera::FrameBufferAllocator> allocator_;
  std::vector<std::unique_ptr<libcamera::Request>> requests_;
  libcamera::Stream* stream_ = nullptr;
  bool acquired_ = false, started_ = false;
  std::mutex send_mutex_;
};

}  // namespace
}  // namespace mm

int main(int argc, char** argv) {
  mm::Args args;
  for (int i = 1; i < argc; ++i) {
    const std::string key = argv[i];
    const std::string value = i + 1 < argc ? argv[i + 1] : "";
    if (key == "--list") {
      args.list = true;
      continue;
    }
    ++i;
    if (key == "--camera") {
      args.camera = value;
    } else if (key == "--width") {
      args.width = std::atoi(value.c_str());
    } else if (key == "--height") {
      args.height = std::atoi(value.c_str());
    } else if (key == "--format") {
      args.format = mm::ParsePixelFormat(value);
    } else {
      std::fprintf(stderr, "mm-libcamera-worker: unknown argument '%s'\n", key.c_str());
      return 2;
    }
  }
  if (fcntl(mm::lcipc::kSocketFd, F_GETFD) < 0) {
    std::fprintf(stderr,
                 "mm-libcamera-worker: no socket on fd %d (started by LibcameraSource only)\n",
                 mm::lcipc::kSocketFd);
    return 2;
  }
  mm::Worker worker(args);
  return worker.Run();
}
