#include "capture/v4l2_source.h"

#include <fcntl.h>
#include <linux/videodev2.h>
#include <poll.h>
#include <sys/ioctl.h>
#include <sys/mman.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <sstream>
#include <thread>

#include "base/poll.h"

namespace mm {
namespace {

int Xioctl(int fd, unsigned long request, void* arg) {
  int r;
  do {
    r = ::ioctl(fd, request, arg);
  } while (r == -1 && errno == EINTR);
  return r;
}

std::string Errno(int err) { return std::strerror(err); }

std::string FpsText(double fps) {
  std::ostringstream s;
  s << std::round(fps * 100) / 100;
  return s.str();
}

std::vector<V4l2FormatOffer> EnumerateOffers(int fd) {
  std::vector<V4l2FormatOffer> offers;
  for (uint32_t i = 0; i < 64; ++i) {
    v4l2_fmtdesc desc{};
    desc.index = i;
    desc.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    if (Xioctl(fd, VIDIOC_ENUM_FMT, &desc) != 0) break;
    V4l2FormatOffer offer;
    offer.fourcc = desc.pixelformat;
    offer.description = reinterpret_cast<const char*>(desc.description);
    for (uint32_t j = 0; j < 64; ++j) {
      v4l2_frmsizeenum size{};
      size.index = j;
      size.pixel_format = desc.pixelformat;
      if (Xioctl(fd, VIDIOC_ENUM_FRAMESIZES, &size) != 0) break;
      if (size.type != V4L2_FRMSIZE_TYPE_DISCRETE) {
        const auto& sw = size.stepwise;
        offer.stepwise = std::to_string(sw.min_width) + "x" + std::to_string(sw.min_height) + "-" +
                         std::to_string(sw.max_width) + "x" + std::to_string(sw.max_height);
        if (size.type == V4L2_FRMSIZE_TYPE_STEPWISE) {
          offer.stepwise += " step " + std::to_string(sw.step_width) + "x" +
                            std::to_string(sw.step_height);
        }
        break;
      }
      V4l2FormatOffer::Size s;
      s.width = static_cast<int>(size.discrete.width);
      s.height = static_cast<int>(size.discrete.height);
      for (uint32_t k = 0; k < 32; ++k) {
        v4l2_frmivalenum ival{};
        ival.index = k;
        ival.pixel_format = desc.pixelformat;
        ival.width = size.discrete.width;
        ival.height = size.discrete.height;
        if (Xioctl(fd, VIDIOC_ENUM_FRAMEINTERVALS, &ival) != 0) break;
        if (ival.type != V4L2_FRMIVAL_TYPE_DISCRETE) break;
        if (ival.discrete.numerator > 0) {
          s.fps.push_back(static_cast<double>(ival.discrete.denominator) / ival.discrete.numerator);
        }
      }
      offer.sizes.push_back(std::move(s));
    }
    offers.push_back(std::move(offer));
  }
  return offers;
}

struct ControlInfo {
  bool present = false;
  int minimum = 0, maximum = 0;
};

ControlInfo QueryControl(int fd, uint32_t id) {
  v4l2_queryctrl q{};
  q.id = id;
  if (Xioctl(fd, VIDIOC_QUERYCTRL, &q) != 0 || (q.flags & V4L2_CTRL_FLAG_DISABLED)) return {};
  return {true, q.minimum, q.maximum};
}

}  // namespace

std::string V4l2Options::Check() const {
  if (device.empty()) return "v4l2: no device path";
  if (width < 0 || height < 0) return "v4l2 " + device + ": width and height must be >= 0";
  if ((width == 0) != (height == 0)) return "v4l2 " + device + ": give both width and height";
  if (!(fps >= 0) || fps > 1000) return "v4l2 " + device + ": fps must be in 0..1000";
  if (buffers < 2 || buffers > 32) return "v4l2 " + device + ": buffers must be in 2..32";
  if (lost_after_ms < 100) return "v4l2 " + device + ": lost_after_ms must be >= 100";
  if (reopen_min_ms < 1 || reopen_max_ms < reopen_min_ms) {
    return "v4l2 " + device + ": need 1 <= reopen_min_ms <= reopen_max_ms";
  }
  return {};
}

std::string DescribeOffers(const std::vector<V4l2FormatOffer>& offers) {
  if (offers.empty()) return "no capture formats";
  std::string out, others;
  for (const V4l2FormatOffer& o : offers) {
    if (!FromFourcc(o.fourcc)) {  // Named only: this build cannot convert it.
      others += (others.empty() ? "" : " ") + FourccName(o.fourcc);
      continue;
    }
    if (!out.empty()) out += "; ";
    out += FourccName(o.fourcc);
    if (!o.stepwise.empty()) out += " " + o.stepwise;
    bool first = true;
    for (const auto& s : o.sizes) {
      out += first ? " " : ", ";
      first = false;
      out += std::to_string(s.width) + "x" + std::to_string(s.height);
      if (s.fps.empty()) continue;
      const auto [lo, hi] = std::minmax_element(s.fps.begin(), s.fps.end());
      out += "@" + (*lo == *hi ? FpsText(*hi) : FpsText(*lo) + "-" + FpsText(*hi)) + "fps";
    }
  }
  if (out.empty()) out = "no format this build converts";
  if (!others.empty()) out += "; not convertible: " + others;
  return out;
}

V4l2Source::V4l2Source(V4l2Options options)
    : options_(std::move(options)),
      recovery_({options_.lost_after_ms, options_.reopen_min_ms, options_.reopen_max_ms}) {
  description_ = "v4l2:" + options_.device + " (not open)";
}

V4l2Source::~V4l2Source() { Close(); }

std::string V4l2Source::Open() {
  if (std::string error = options_.Check(); !error.empty()) return error;
  Close();
  std::string error = OpenDevice();
  if (!error.empty()) return error;
  opened_ = true;
  recovery_.Reset();
  return {};
}

std::string V4l2Source::OpenDevice() {
  const std::string& dev = options_.device;
  const std::string where = "v4l2 " + dev + ": ";
  UniqueFd fd(::open(dev.c_str(), O_RDWR | O_NONBLOCK | O_CLOEXEC));
  if (!fd.valid()) {
    const int err = errno;
    if (err == ENOENT) return where + "no such device (is the camera plugged in?)";
    if (err == EACCES) return where + "permission denied (add the user to group 'video')";
    if (err == EBUSY) return where + "device busy (opened by another process)";
    return where + "cannot open: " + Errno(err);
  }
  v4l2_capability cap{};
  if (Xioctl(fd.get(), VIDIOC_QUERYCAP, &cap) != 0) {
    return where + "not a V4L2 device (VIDIOC_QUERYCAP: " + Errno(errno) + ")";
  }
  const uint32_t caps = (cap.capabilities & V4L2_CAP_DEVICE_CAPS) ? cap.device_caps : cap.capabilities;
  card_ = reinterpret_cast<const char*>(cap.card);
  if (!(caps & V4L2_CAP_VIDEO_CAPTURE)) {
    std::string why = (caps & V4L2_CAP_VIDEO_CAPTURE_MPLANE)
                          ? "only multi-planar capture, which this build does not support"
                          : "no video capture capability";
    return where + "'" + card_ + "' has " + why;
  }
  if (!(caps & V4L2_CAP_STREAMING)) return where + "'" + card_ + "' does not support streaming I/O";

  offers_ = EnumerateOffers(fd.get());
  const std::string offered = "device '" + card_ + "' offers: " + DescribeOffers(offers_);

  // Format: the requested one, or the first convertible one offered, or the current one.
  v4l2_format fmt{};
  fmt.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  if (Xioctl(fd.get(), VIDIOC_G_FMT, &fmt) != 0) {
    if (offers_.empty()) {
      return where + "offers no format yet (a v4l2loopback device with no writer?)";
    }
    fmt = {};
    fmt.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  }
  uint32_t want = 0;
  if (options_.format) {
    want = ToFourcc(*options_.format);
    bool offered_it = offers_.empty();  // Some drivers enumerate nothing; let S_FMT decide.
    for (const auto& o : offers_) {
      if (o.fourcc == want || (FromFourcc(o.fourcc) == options_.format)) {
        offered_it = true;
        want = o.fourcc;
      }
    }
    if (!offered_it) {
      return where + "format " + PixelFormatName(*options_.format) + " not offered; " + offered;
    }
  } else if (FromFourcc(fmt.fmt.pix.pixelformat)) {
    want = fmt.fmt.pix.pixelformat;
  } else {
    for (const auto& o : offers_) {
      if (FromFourcc(o.fourcc)) {
        want = o.fourcc;
        break;
      }
    }
    if (want == 0) return where + "no format this build can convert (GREY, YUYV, NV12, MJPG, BGR3, RGB3); " + offered;
  }
  fmt.fmt.pix.pixelformat = want;
  if (options_.width > 0) {
    fmt.fmt.pix.width = static_cast<uint32_t>(options_.width);
    fmt.fmt.pix.height = static_cast<uint32_t>(options_.height);
  }
  fmt.fmt.pix.field = V4L2_FIELD_NONE;
  fmt.fmt.pix.bytesperline = 0;
  if (Xioctl(fd.get(), VIDIOC_S_FMT, &fmt) != 0) {
    const int err = errno;
    if (err == EBUSY) return where + "device busy (another process is streaming from it)";
    return where + "VIDIOC_S_FMT " + FourccName(want) + ": " + Errno(err) + "; " + offered;
  }
  if (fmt.fmt.pix.pixelformat != want) {
    return where + "asked for " + FourccName(want) + ", the driver chose " +
           FourccName(fmt.fmt.pix.pixelformat) + "; " + offered;
  }
  if (options_.width > 0 && (static_cast<int>(fmt.fmt.pix.width) != options_.width ||
                             static_cast<int>(fmt.fmt.pix.height) != options_.height)) {
    return where + FourccName(want) + " " + std::to_string(options_.width) + "x" +
           std::to_string(options_.height) + " not offered (the driver chose " +
           std::to_string(fmt.fmt.pix.width) + "x" + std::to_string(fmt.fmt.pix.height) + "); " +
           offered;
  }
  format_ = *FromFourcc(want);
  fourcc_ = want;
  width_ = static_cast<int>(fmt.fmt.pix.width);
  height_ = static_cast<int>(fmt.fmt.pix.height);
  stride_ = fmt.fmt.pix.bytesperline;

  // Frame rate.
  v4l2_streamparm parm{};
  parm.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  if (options_.fps > 0) {
    parm.parm.capture.timeperframe.numerator = 1000;
    parm.parm.capture.timeperframe.denominator = static_cast<uint32_t>(std::lround(options_.fps * 1000));
    if (Xioctl(fd.get(), VIDIOC_S_PARM, &parm) != 0) {
      return where + "cannot set " + FpsText(options_.fps) + " fps (" + Errno(errno) + "); " + offered;
    }
  } else {
    Xioctl(fd.get(), VIDIOC_G_PARM, &parm);
  }
  const auto& tpf = parm.parm.capture.timeperframe;
  fps_ = tpf.numerator ? static_cast<double>(tpf.denominator) / tpf.numerator : 0.0;
  if (options_.fps > 0 && fps_ > 0 && std::abs(fps_ - options_.fps) > 0.01 * options_.fps) {
    return where + FourccName(want) + " " + std::to_string(width_) + "x" + std::to_string(height_) +
           " at " + FpsText(options_.fps) + " fps not offered (the driver chose " + FpsText(fps_) +
           "); " + offered;
  }

  fd_ = std::move(fd);
  if (std::string error = SetControls(); !error.empty()) {
    fd_.reset();
    return error;
  }

  // Buffers.
  v4l2_requestbuffers req{};
  req.count = static_cast<uint32_t>(options_.buffers);
  req.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  req.memory = V4L2_MEMORY_MMAP;
  if (Xioctl(fd_.get(), VIDIOC_REQBUFS, &req) != 0) {
    const int err = errno;
    fd_.reset();
    if (err == EBUSY) return where + "device busy (another process is streaming from it)";
    return where + "VIDIOC_REQBUFS: " + Errno(err);
  }
  if (req.count < 2) {
    fd_.reset();
    return where + "the driver gave " + std::to_string(req.count) + " buffer(s), need 2";
  }
  for (uint32_t i = 0; i < req.count; ++i) {
    v4l2_buffer buf{};
    buf.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    buf.memory = V4L2_MEMORY_MMAP;
    buf.index = i;
    if (Xioctl(fd_.get(), VIDIOC_QUERYBUF, &buf) != 0) {
      const std::string e = where + "VIDIOC_QUERYBUF: " + Errno(errno);
      CloseDevice();
      return e;
    }
    void* addr = ::mmap(nullptr, buf.length, PROT_READ | PROT_WRITE, MAP_SHARED, fd_.get(),
                        buf.m.offset);
    if (addr == MAP_FAILED) {
      const std::string e = where + "mmap: " + Errno(errno);
      CloseDevice();
      return e;
    }
    buffers_.push_back({addr, buf.length});
    if (Xioctl(fd_.get(), VIDIOC_QBUF, &buf) != 0) {
      const std::string e = where + "VIDIOC_QBUF: " + Errno(errno);
      CloseDevice();
      return e;
    }
  }
  v4l2_buf_type type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  if (Xioctl(fd_.get(), VIDIOC_STREAMON, &type) != 0) {
    const int err = errno;
    CloseDevice();
    if (err == EBUSY) return where + "device busy (another process is streaming from it)";
    return where + "VIDIOC_STREAMON: " + Errno(err);
  }
  streaming_ = true;
  recovery_.FrameArrived();  // The silence clock starts with the stream.
  {
    std::lock_guard lock(describe_mutex_);
    description_ = "v4l2:" + dev + " '" + card_ + "' " + FourccName(fourcc_) + " " +
                   std::to_string(width_) + "x" + std::to_string(height_) +
                   (fps_ > 0 ? "@" + FpsText(fps_) : std::string()) + " -> " +
                   (options_.gray ? "GRAY8" : "BGR8") + ", " + std::to_string(buffers_.size()) +
                   " mmap buffers";
  }
  return {};
}

std::string V4l2Source::SetControls() {
  const std::string where = "v4l2 " + options_.device + ": ";
  auto set = [&](uint32_t id, int value) -> bool {
    v4l2_control c{};
    c.id = id;
    c.value = value;
    return Xioctl(fd_.get(), VIDIOC_S_CTRL, &c) == 0;
  };
  if (options_.exposure) {
    const ControlInfo info = QueryControl(fd_.get(), V4L2_CID_EXPOSURE_ABSOLUTE);
    const uint32_t id = info.present ? V4L2_CID_EXPOSURE_ABSOLUTE : V4L2_CID_EXPOSURE;
    const ControlInfo used = info.present ? info : QueryControl(fd_.get(), V4L2_CID_EXPOSURE);
    if (!used.present) return where + "'" + card_ + "' has no exposure control";
    if (QueryControl(fd_.get(), V4L2_CID_EXPOSURE_AUTO).present) {
      set(V4L2_CID_EXPOSURE_AUTO, V4L2_EXPOSURE_MANUAL);
    }
    if (*options_.exposure < used.minimum || *options_.exposure > used.maximum) {
      return where + "exposure " + std::to_string(*options_.exposure) + " outside " +
             std::to_string(used.minimum) + ".." + std::to_string(used.maximum);
    }
    if (!set(id, *options_.exposure)) return where + "setting exposure: " + Errno(errno);
  }
  if (options_.gain) {
    ControlInfo info = QueryControl(fd_.get(), V4L2_CID_GAIN);
    uint32_t id = V4L2_CID_GAIN;
    if (!info.present) {
      info = QueryControl(fd_.get(), V4L2_CID_ANALOGUE_GAIN);
      id = V4L2_CID_ANALOGUE_GAIN;
    }
    if (!info.present) return where + "'" + card_ + "' has no gain control";
    if (QueryControl(fd_.get(), V4L2_CID_AUTOGAIN).present) set(V4L2_CID_AUTOGAIN, 0);
    if (*options_.gain < info.minimum || *options_.gain > info.maximum) {
      return where + "gain " + std::to_string(*options_.gain) + " outside " +
             std::to_string(info.minimum) + ".." + std::to_string(info.maximum);
    }
    if (!set(id, *options_.gain)) return where + "setting gain: " + Errno(errno);
  }
  return {};
}

void V4l2Source::UnmapBuffers() {
  for (const Buffer& b : buffers_) ::munmap(b.addr, b.length);
  buffers_.clear();
}

void V4l2Source::CloseDevice() {
  if (fd_.valid() && streaming_) {
    v4l2_buf_type type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    Xioctl(fd_.get(), VIDIOC_STREAMOFF, &type);
  }
  streaming_ = false;
  UnmapBuffers();
  fd_.reset();
}

void V4l2Source::Close() {
  CloseDevice();
  opened_ = false;
  recovery_.Reset();
}

std::string V4l2Source::Lose(const std::string& why) {
  CloseDevice();
  recovery_.Lose();
  {
    std::lock_guard lock(describe_mutex_);
    description_ = "v4l2:" + options_.device + " (lost: " + why + "; reopening)";
  }
  return "v4l2 " + options_.device + ": device lost (" + why + "); reopening with back-off";
}

ReadStatus V4l2Source::Read(Frame* frame, std::chrono::milliseconds timeout, std::string* error) {
  using Clock = std::chrono::steady_clock;
  const auto deadline = Clock::now() + timeout;
  if (!opened_) {
    if (error) *error = "v4l2 " + options_.device + ": Read() before Open()";
    return ReadStatus::kError;
  }
  if (recovery_.lost()) {
    if (!recovery_.AttemptDue(deadline)) return ReadStatus::kTimeout;
    last_reopen_error_ = OpenDevice();
    if (!last_reopen_error_.empty()) {
      recovery_.AttemptFailed();
      std::lock_guard lock(describe_mutex_);
      description_ = "v4l2:" + options_.device + " (lost; last reopen: " + last_reopen_error_ +
                     "; next in " + std::to_string(recovery_.backoff_ms()) + " ms)";
      return ReadStatus::kTimeout;
    }
    recovery_.AttemptSucceeded();
  }

  while (true) {
    const int revents = PollReadable(fd_.get(), deadline);
    if (revents < 0) {
      if (error) *error = Lose("poll: " + Errno(errno));
      return ReadStatus::kError;
    }
    if (revents == 0) {
      if (recovery_.Silent()) {
        if (error) {
          *error = Lose("no frame for " + std::to_string(options_.lost_after_ms) + " ms");
        } else {
          Lose("timeout");
        }
        return ReadStatus::kError;
      }
      return ReadStatus::kTimeout;
    }
    v4l2_buffer buf{};
    buf.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    buf.memory = V4L2_MEMORY_MMAP;
    if (Xioctl(fd_.get(), VIDIOC_DQBUF, &buf) != 0) {
      const int err = errno;
      if (err == EAGAIN && !(revents & (POLLERR | POLLHUP))) {
        if (Clock::now() >= deadline) return ReadStatus::kTimeout;
        continue;
      }
      const std::string why = (revents & POLLERR) && err == EAGAIN
                                  ? std::string("POLLERR")
                                  : "VIDIOC_DQBUF: " + Errno(err);
      if (error) *error = Lose(why);
      return ReadStatus::kError;
    }
    const Buffer& mapped = buffers_.at(buf.index);
    std::string convert_error;
    const bool bad = (buf.flags & V4L2_BUF_FLAG_ERROR) || buf.bytesused == 0;
    if (!bad) {
      const auto* data = static_cast<const uint8_t*>(mapped.addr);
      const size_t size = std::min<size_t>(buf.bytesused, mapped.length);
      frame->image = cv::Mat();
      convert_error = ConvertFrame(format_, data, size, width_, height_, stride_, options_.gray,
                                   &decoder_, &frame->image);
    }
    // Give the buffer back before anything else can fail.
    if (Xioctl(fd_.get(), VIDIOC_QBUF, &buf) != 0) {
      if (error) *error = Lose("VIDIOC_QBUF: " + Errno(errno));
      return ReadStatus::kError;
    }
    recovery_.FrameArrived();
    if (bad) {
      if (Clock::now() >= deadline) return ReadStatus::kTimeout;
      continue;  // A corrupt buffer from the driver: skip it.
    }
    if (!convert_error.empty()) {
      if (error) *error = "v4l2 " + options_.device + ": " + convert_error;
      return ReadStatus::kError;
    }
    const int64_t driver_ns = static_cast<int64_t>(buf.timestamp.tv_sec) * 1000000000LL +
                              static_cast<int64_t>(buf.timestamp.tv_usec) * 1000LL;
    const bool monotonic = (buf.flags & V4L2_BUF_FLAG_TIMESTAMP_MASK) ==
                           V4L2_BUF_FLAG_TIMESTAMP_MONOTONIC;
    frame->capture_time_ns = (monotonic && driver_ns > 0) ? driver_ns : MonotonicNowNs();
    frame->source_time_s = static_cast<double>(driver_ns) * 1e-9;
    frame->sequence = sequence_++;
    frame->source_id = options_.device;
    return ReadStatus::kFrame;
  }
}

std::string V4l2Source::Describe() const {
  std::lock_guard lock(describe_mutex_);
  return description_;
}

}  // namespace mm
