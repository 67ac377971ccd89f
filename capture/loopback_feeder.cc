#include "capture/loopback_feeder.h"

#include <fcntl.h>
#include <linux/videodev2.h>
#include <sys/ioctl.h>
#include <unistd.h>

#include <cerrno>
#include <cmath>
#include <cstring>
#include <opencv2/imgproc.hpp>

namespace mm {

std::string EncodeForFeed(const cv::Mat& bgr, PixelFormat format, std::string* bytes) {
  if (bgr.type() != CV_8UC3) return "feeder: expected a BGR8 image";
  if (format == PixelFormat::kGrey) {
    cv::Mat gray;
    cv::cvtColor(bgr, gray, cv::COLOR_BGR2GRAY);
    bytes->assign(reinterpret_cast<const char*>(gray.data), gray.total());
    return {};
  }
  if (format == PixelFormat::kYuyv) {
    if (bgr.cols % 2 != 0) return "feeder: YUYV needs an even width";
    BgrToYuyv(bgr, bytes);
    return {};
  }
  return "feeder: format " + PixelFormatName(format) + " cannot be fed (use grey or yuyv)";
}

std::string LoopbackFeeder::Open(const std::string& device, int width, int height,
                                 PixelFormat format, double fps) {
  device_ = device;
  const std::string where = "feed " + device + ": ";
  if (format != PixelFormat::kGrey && format != PixelFormat::kYuyv) {
    return where + "format " + PixelFormatName(format) + " cannot be fed (use grey or yuyv)";
  }
  UniqueFd fd(::open(device.c_str(), O_RDWR | O_CLOEXEC));
  if (!fd.valid()) {
    const int err = errno;
    if (err == ENOENT) return where + "no such device (modprobe v4l2loopback?)";
    return where + "cannot open: " + std::strerror(err);
  }
  v4l2_capability cap{};
  if (::ioctl(fd.get(), VIDIOC_QUERYCAP, &cap) != 0) return where + "not a V4L2 device";
  const uint32_t caps = (cap.capabilities & V4L2_CAP_DEVICE_CAPS) ? cap.device_caps : cap.capabilities;
  if (!(caps & V4L2_CAP_VIDEO_OUTPUT)) {
    return where + "'" + reinterpret_cast<const char*>(cap.card) +
           "' has no video output (is it a v4l2loopback device?)";
  }
  v4l2_format fmt{};
  fmt.type = V4L2_BUF_TYPE_VIDEO_OUTPUT;
  fmt.fmt.pix.width = static_cast<uint32_t>(width);
  fmt.fmt.pix.height = static_cast<uint32_t>(height);
  fmt.fmt.pix.pixelformat = ToFourcc(format);
  fmt.fmt.pix.field = V4L2_FIELD_NONE;
  fmt.fmt.pix.bytesperline = static_cast<uint32_t>(format == PixelFormat::kYuyv ? 2 * width : width);
  fmt.fmt.pix.sizeimage = static_cast<uint32_t>(FrameBytes(format, width, height));
  fmt.fmt.pix.colorspace = V4L2_COLORSPACE_SRGB;
  if (::ioctl(fd.get(), VIDIOC_S_FMT, &fmt) != 0) {
    const int err = errno;
    if (err == EBUSY) return where + "busy (another writer, or a reader holds another format)";
    return where + "VIDIOC_S_FMT: " + std::strerror(err);
  }
  if (fmt.fmt.pix.pixelformat != ToFourcc(format) ||
      static_cast<int>(fmt.fmt.pix.width) != width || static_cast<int>(fmt.fmt.pix.height) != height) {
    return where + "the device kept " + FourccName(fmt.fmt.pix.pixelformat) + " " +
           std::to_string(fmt.fmt.pix.width) + "x" + std::to_string(fmt.fmt.pix.height);
  }
  if (fps > 0) {
    v4l2_streamparm parm{};
    parm.type = V4L2_BUF_TYPE_VIDEO_OUTPUT;
    parm.parm.output.timeperframe.numerator = 1000;
    parm.parm.output.timeperframe.denominator = static_cast<uint32_t>(std::lround(fps * 1000));
    ::ioctl(fd.get(), VIDIOC_S_PARM, &parm);  // Advisory only.
  }
  fd_ = std::move(fd);
  width_ = width;
  height_ = height;
  format_ = format;
  return {};
}

std::string LoopbackFeeder::Write(const cv::Mat& bgr) {
  if (bgr.cols != width_ || bgr.rows != height_) {
    return "feed " + device_ + ": frame is " + std::to_string(bgr.cols) + "x" +
           std::to_string(bgr.rows) + ", the device was set to " + std::to_string(width_) + "x" +
           std::to_string(height_);
  }
  if (std::string e = EncodeForFeed(bgr, format_, &scratch_); !e.empty()) return e;
  return WriteRaw(scratch_);
}

std::string LoopbackFeeder::WriteRaw(const std::string& bytes) {
  if (!fd_.valid()) return "feed " + device_ + ": not open";
  size_t done = 0;
  while (done < bytes.size()) {
    const ssize_t n = ::write(fd_.get(), bytes.data() + done, bytes.size() - done);
    if (n < 0) {
      if (errno == EINTR) continue;
      return "feed " + device_ + ": write: " + std::strerror(errno);
    }
    done += static_cast<size_t>(n);
  }
  return {};
}

}  // namespace mm
