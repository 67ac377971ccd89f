#include "capture/libcamera_source.h"

#include <sys/mman.h>

#include <charconv>
#include <libcamera/libcamera.h>
#include <thread>

namespace mm {
namespace {

// libcamera allows one CameraManager per process: shared by every source and lister.
std::shared_ptr<libcamera::CameraManager> SharedManager(std::string* error) {
  static std::mutex mutex;
  static std::weak_ptr<libcamera::CameraManager> weak;
  std::lock_guard lock(mutex);
  if (auto m = weak.lock()) return m;
  auto m = std::make_shared<libcamera::CameraManager>();
  if (const int r = m->start(); r != 0) {
    if (error) *error = "libcamera: CameraManager::start: " + std::string(strerror(-r));
    return nullptr;
  }
  weak = m;
  return m;
}

std::optional<PixelFormat> FromLibcamera(const libcamera::PixelFormat& f) {
  if (f == libcamera::formats::YUYV) return PixelFormat::kYuyv;
  if (f == libcamera::formats::NV12) return PixelFormat::kNv12;
  if (f == libcamera::formats::R8) return PixelFormat::kGrey;
  if (f == libcamera::formats::MJPEG) return PixelFormat::kMjpeg;
  if (f == libcamera::formats::RGB888) return PixelFormat::kBgr24;  // DRM order: bytes B,G,R.
  if (f == libcamera::formats::BGR888) return PixelFormat::kRgb24;
  return std::nullopt;
}

}  // namespace

std::vector<std::string> ListLibcameraCameras(std::string* error) {
  std::vector<std::string> ids;
  auto m = SharedManager(error);
  if (!m) return ids;
  for (const auto& c : m->cameras()) ids.push_back(c->id());
  return ids;
}

LibcameraSource::LibcameraSource(LibcameraOptions options)
    : options_(std::move(options)),
      recovery_({options_.lost_after_ms, options_.reopen_min_ms, options_.reopen_max_ms}) {
  description_ = "libcamera:" + options_.camera + " (not open)";
}

LibcameraSource::~LibcameraSource() { Close(); }

std::string LibcameraSource::Open() {
  Close();
  if (std::string e = OpenCamera(); !e.empty()) return e;
  opened_ = true;
  recovery_.Reset();
  return {};
}

std::string LibcameraSource::OpenCamera() {
  const std::string where = "libcamera " + options_.camera + ": ";
  std::string error;
  manager_ = SharedManager(&error);
  if (!manager_) return where + error;
  const auto cameras = manager_->cameras();
  std::string listed;
  for (size_t i = 0; i < cameras.size(); ++i) {
    listed += (i ? ", " : "") + std::to_string(i) + "='" + cameras[i]->id() + "'";
  }
  if (listed.empty()) listed = "none";
  const std::string& want = id_.empty() ? options_.camera : id_;
  camera_ = manager_->get(want);
  size_t index = 0;
  const auto r = std::from_chars(want.data(), want.data() + want.size(), index);
  if (!camera_ && r.ec == std::errc() && r.ptr == want.data() + want.size() && index < cameras.size()) {
    camera_ = cameras[index];
  }
  if (!camera_) return where + "no such camera (libcamera lists: " + listed + ")";
  id_ = camera_->id();
  if (camera_->acquire() != 0) {
    camera_.reset();
    return where + "camera busy (acquired by another process)";
  }
  acquired_ = true;
  camera_->disconnected.connect(this, &LibcameraSource::OnDisconnected);
  std::unique_ptr<libcamera::CameraConfiguration> config =
      camera_->generateConfiguration({libcamera::StreamRole::Viewfinder});
  if (!config || config->empty()) {
    CloseCamera();
    return where + "no viewfinder configuration";
  }
  libcamera::StreamConfiguration& sc = config->at(0);
  std::string offered;
  std::optional<libcamera::PixelFormat> chosen;
  for (const libcamera::PixelFormat& f : sc.formats().pixelformats()) {
    offered += (offered.empty() ? "" : " ") + f.toString();
    const auto ours = FromLibcamera(f);
    if (!ours) continue;
    if (options_.format ? *ours == *options_.format : !chosen) chosen = f;
  }
  if (!chosen && FromLibcamera(sc.pixelFormat) && !options_.format) chosen = sc.pixelFormat;
  if (!chosen) {
    CloseCamera();
    return where + (options_.format ? "format " + PixelFormatName(*options_.format) + " not offered"
                                    : std::string("no format this build converts")) +
           "; the stream offers: " + offered;
  }
  sc.pixelFormat = *chosen;
  if (options_.width > 0) sc.size = libcamera::Size(options_.width, options_.height);
  sc.bufferCount = std::max(sc.bufferCount, 4u);
  const auto status = config->validate();
  if (status == libcamera::CameraConfiguration::Invalid) {
    CloseCamera();
    return where + "configuration invalid; the stream offers: " + offered;
  }
  if (sc.pixelFormat != *chosen ||
      (options_.width > 0 && (static_cast<int>(sc.size.width) != options_.width ||
                              static_cast<int>(sc.size.height) != options_.height))) {
    const std::string got = sc.toString();
    CloseCamera();
    return where + "asked for " + chosen->toString() + " " + std::to_string(options_.width) + "x" +
           std::to_string(options_.height) + ", the pipeline adjusted it to " + got +
           "; the stream offers: " + offered;
  }
  if (camera_->configure(config.get()) != 0) {
    CloseCamera();
    return where + "Camera::configure failed";
  }
  stream_ = sc.stream();
  format_ = *FromLibcamera(sc.pixelFormat);
  width_ = static_cast<int>(sc.size.width);
  height_ = static_cast<int>(sc.size.height);
  stride_ = sc.stride;
  allocator_ = std::make_unique<libcamera::FrameBufferAllocator>(camera_);
  if (allocator_->allocate(stream_) < 0) {
    CloseCamera();
    return where + "cannot allocate buffers";
  }
  for (const auto& buffer : allocator_->buffers(stream_)) {
    // Planes share one dmabuf: map it once, from the first plane's offset 0.
    size_t length = 0;
    for (const auto& plane : buffer->planes()) length = std::max<size_t>(length, plane.offset + plane.length);
    void* addr = mmap(nullptr, length, PROT_READ, MAP_SHARED, buffer->planes()[0].fd.get(), 0);
    if (addr == MAP_FAILED) {
      CloseCamera();
      return where + "mmap of a frame buffer failed";
    }
    mappings_.push_back({addr, length});
    std::unique_ptr<libcamera::Request> request = camera_->createRequest(mappings_.size() - 1);
    if (!request || request->addBuffer(stream_, buffer.get()) != 0) {
      CloseCamera();
      return where + "cannot create a request";
    }
    requests_.push_back(std::move(request));
  }
  camera_->requestCompleted.connect(this, &LibcameraSource::OnRequestCompleted);
  if (camera_->start() != 0) {
    CloseCamera();
    return where + "Camera::start failed";
  }
  started_ = true;
  for (auto& request : requests_) camera_->queueRequest(request.get());
  recovery_.FrameArrived();  // The silence clock starts with the stream.
  std::lock_guard lock(describe_mutex_);
  description_ = "libcamera:" + id_ + " " + sc.toString() + " -> " + (options_.gray ? "GRAY8" : "BGR8");
  return {};
}

void LibcameraSource::OnRequestCompleted(libcamera::Request* request) {
  if (request->status() == libcamera::Request::RequestCancelled) return;
  {
    std::lock_guard lock(mutex_);
    completed_.push_back(request);
  }
  cv_.notify_all();
}

void LibcameraSource::OnDisconnected() {
  {
    std::lock_guard lock(mutex_);
    disconnected_ = true;
  }
  cv_.notify_all();
}

void LibcameraSource::CloseCamera() {
  if (camera_) {
    if (started_) camera_->stop();
    camera_->requestCompleted.disconnect(this);
    camera_->disconnected.disconnect(this);
  }
  started_ = false;
  {
    std::lock_guard lock(mutex_);
    completed_.clear();
    disconnected_ = false;
  }
  requests_.clear();
  for (const Mapping& m : mappings_) munmap(m.addr, m.length);
  mappings_.clear();
  if (allocator_ && stream_) allocator_->free(stream_);
  allocator_.reset();
  stream_ = nullptr;
  if (camera_ && acquired_) camera_->release();
  acquired_ = false;
  camera_.reset();
}

void LibcameraSource::Close() {
  CloseCamera();
  manager_.reset();
  opened_ = false;
  recovery_.Reset();
}

std::string LibcameraSource::Lose(const std::string& why) {
  CloseCamera();
  // Drop our hold on the CameraManager too: without udev hotplug events (no udevd, or a
  // pipeline that never signals disconnected) a manager keeps its stale camera list, and only
  // a new one enumerates the camera when it comes back.
  manager_.reset();
  recovery_.Lose();
  std::lock_guard lock(describe_mutex_);
  description_ = "libcamera:" + (id_.empty() ? options_.camera : id_) + " (lost: " + why + "; reopening)";
  return "libcamera " + (id_.empty() ? options_.camera : id_) + ": camera lost (" + why +
         "); reopening with back-off";
}

ReadStatus LibcameraSource::Read(Frame* frame, std::chrono::milliseconds timeout, std::string* error) {
  using Clock = std::chrono::steady_clock;
  const auto deadline = Clock::now() + timeout;
  if (!opened_) {
    if (error) *error = "libcamera " + options_.camera + ": Read() before Open()";
    return ReadStatus::kError;
  }
  if (recovery_.lost()) {
    if (!recovery_.AttemptDue(deadline)) return ReadStatus::kTimeout;
    if (!OpenCamera().empty()) {
      manager_.reset();  // Enumerate afresh on the next attempt (see Lose()).
      recovery_.AttemptFailed();
      return ReadStatus::kTimeout;
    }
    recovery_.AttemptSucceeded();
  }
  libcamera::Request* request = nullptr;
  {
    std::unique_lock lock(mutex_);
    cv_.wait_until(lock, deadline, [&] { return !completed_.empty() || disconnected_; });
    if (disconnected_) {
      lock.unlock();
      const std::string e = Lose("disconnected");
      if (error) *error = e;
      return ReadStatus::kError;
    }
    if (completed_.empty()) {
      lock.unlock();
      if (recovery_.Silent()) {
        const std::string e = Lose("no frame for " + std::to_string(options_.lost_after_ms) + " ms");
        if (error) *error = e;
        return ReadStatus::kError;
      }
      return ReadStatus::kTimeout;
    }
    request = completed_.front();
    completed_.pop_front();
  }
  recovery_.FrameArrived();
  libcamera::FrameBuffer* buffer = request->findBuffer(stream_);
  const libcamera::FrameMetadata& md = buffer->metadata();
  const Mapping& m = mappings_.at(request->cookie());
  const auto* data = static_cast<const uint8_t*>(m.addr) + buffer->planes()[0].offset;
  size_t used = 0;
  for (const auto& p : md.planes()) used += p.bytesused;
  std::string convert_error;
  const bool ok = md.status == libcamera::FrameMetadata::FrameSuccess;
  if (ok) {
    const size_t size = m.length - buffer->planes()[0].offset;
    convert_error = format_ == PixelFormat::kMjpeg
                        ? decoder_.Decode(data, used, options_.gray, &frame->image)
                        : ConvertRaw(format_, data, size, width_, height_, stride_, options_.gray, &frame->image);
  }
  const uint64_t driver_ns = md.timestamp;
  request->reuse(libcamera::Request::ReuseBuffers);
  camera_->queueRequest(request);
  if (!ok) return ReadStatus::kTimeout;
  if (!convert_error.empty()) {
    if (error) *error = "libcamera " + id_ + ": " + convert_error;
    return ReadStatus::kError;
  }
  frame->capture_time_ns = driver_ns ? static_cast<int64_t>(driver_ns) : MonotonicNowNs();
  frame->source_time_s = static_cast<double>(driver_ns) * 1e-9;
  frame->sequence = sequence_++;
  frame->source_id = id_;
  return ReadStatus::kFrame;
}

std::string LibcameraSource::Describe() const {
  std::lock_guard lock(describe_mutex_);
  return description_;
}

}  // namespace mm
