#include "capture/pixel_format.h"

#include <linux/videodev2.h>
#include <turbojpeg.h>

#include <algorithm>
#include <cctype>
#include <opencv2/imgproc.hpp>

namespace mm {

uint32_t ToFourcc(PixelFormat format) {
  switch (format) {
    case PixelFormat::kGrey: return V4L2_PIX_FMT_GREY;
    case PixelFormat::kYuyv: return V4L2_PIX_FMT_YUYV;
    case PixelFormat::kNv12: return V4L2_PIX_FMT_NV12;
    case PixelFormat::kMjpeg: return V4L2_PIX_FMT_MJPEG;
    case PixelFormat::kBgr24: return V4L2_PIX_FMT_BGR24;
    case PixelFormat::kRgb24: return V4L2_PIX_FMT_RGB24;
  }
  return 0;
}

std::optional<PixelFormat> FromFourcc(uint32_t fourcc) {
  switch (fourcc) {
    case V4L2_PIX_FMT_GREY: return PixelFormat::kGrey;
    case V4L2_PIX_FMT_YUYV: return PixelFormat::kYuyv;
    case V4L2_PIX_FMT_NV12: return PixelFormat::kNv12;
    case V4L2_PIX_FMT_MJPEG: return PixelFormat::kMjpeg;
    case V4L2_PIX_FMT_JPEG: return PixelFormat::kMjpeg;
    case V4L2_PIX_FMT_BGR24: return PixelFormat::kBgr24;
    case V4L2_PIX_FMT_RGB24: return PixelFormat::kRgb24;
    default: return std::nullopt;
  }
}

std::string FourccName(uint32_t fourcc) {
  std::string s;
  for (int i = 0; i < 4; ++i) {
    const char c = static_cast<char>((fourcc >> (8 * i)) & 0xff);
    s += std::isprint(static_cast<unsigned char>(c)) ? c : '?';
  }
  while (!s.empty() && s.back() == ' ') s.pop_back();
  return s;
}

std::string PixelFormatName(PixelFormat format) {
  switch (format) {
    case PixelFormat::kGrey: return "grey";
    case PixelFormat::kYuyv: return "yuyv";
    case PixelFormat::kNv12: return "nv12";
    case PixelFormat::kMjpeg: return "mjpeg";
    case PixelFormat::kBgr24: return "bgr24";
    case PixelFormat::kRgb24: return "rgb24";
  }
  return "?";
}

std::optional<PixelFormat> ParsePixelFormat(const std::string& name) {
  std::string n = name;
  std::transform(n.begin(), n.end(), n.begin(), [](unsigned char c) { return std::tolower(c); });
  if (n == "grey" || n == "gray") return PixelFormat::kGrey;
  if (n == "yuyv" || n == "yuy2") return PixelFormat::kYuyv;
  if (n == "nv12") return PixelFormat::kNv12;
  if (n == "mjpeg" || n == "mjpg" || n == "jpeg") return PixelFormat::kMjpeg;
  if (n == "bgr24" || n == "bgr3") return PixelFormat::kBgr24;
  if (n == "rgb24" || n == "rgb3") return PixelFormat::kRgb24;
  return std::nullopt;
}

size_t FrameBytes(PixelFormat format, int width, int height) {
  const size_t w = static_cast<size_t>(width), h = static_cast<size_t>(height);
  switch (format) {
    case PixelFormat::kGrey: return w * h;
    case PixelFormat::kYuyv: return 2 * w * h;
    case PixelFormat::kNv12: return w * h + w * h / 2;
    case PixelFormat::kMjpeg: return 0;
    case PixelFormat::kBgr24:
    case PixelFormat::kRgb24: return 3 * w * h;
  }
  return 0;
}

std::string ConvertRaw(PixelFormat format, const uint8_t* data, size_t size, int width, int height,
                       size_t stride, bool gray, cv::Mat* out) {
  if (width <= 0 || height <= 0) return "bad frame size " + std::to_string(width) + "x" +
                                        std::to_string(height);
  const size_t w = static_cast<size_t>(width), h = static_cast<size_t>(height);
  const size_t min_stride = format == PixelFormat::kYuyv                                 ? 2 * w
                            : format == PixelFormat::kBgr24 || format == PixelFormat::kRgb24 ? 3 * w
                                                                                             : w;
  if (stride == 0) stride = min_stride;
  if (stride < min_stride) {
    return "line stride " + std::to_string(stride) + " < " + std::to_string(min_stride);
  }
  const size_t needed = format == PixelFormat::kNv12 ? stride * h + stride * ((h + 1) / 2)
                                                     : stride * (h - 1) + min_stride;
  if (format == PixelFormat::kMjpeg) return "ConvertRaw: MJPEG needs MjpegDecoder";
  if (size < needed) {
    return "short frame: " + std::to_string(size) + " bytes, " + std::to_string(needed) +
           " expected for " + PixelFormatName(format) + " " + std::to_string(width) + "x" +
           std::to_string(height) + " stride " + std::to_string(stride);
  }
  auto* base = const_cast<uint8_t*>(data);  // cv::Mat headers over const data, read only.
  switch (format) {
    case PixelFormat::kGrey: {
      const cv::Mat src(height, width, CV_8UC1, base, stride);
      if (gray) {
        src.copyTo(*out);
      } else {
        cv::cvtColor(src, *out, cv::COLOR_GRAY2BGR);
      }
      return {};
    }
    case PixelFormat::kYuyv: {
      const cv::Mat src(height, width, CV_8UC2, base, stride);
      if (gray) {
        // Luma is every other byte: a direct copy, no arithmetic.
        out->create(height, width, CV_8UC1);
        for (int y = 0; y < height; ++y) {
          const uint8_t* s = data + static_cast<size_t>(y) * stride;
          uint8_t* d = out->ptr<uint8_t>(y);
          for (int x = 0; x < width; ++x) d[x] = s[2 * x];
        }
      } else {
        cv::cvtColor(src, *out, cv::COLOR_YUV2BGR_YUYV);
      }
      return {};
    }
    case PixelFormat::kNv12: {
      const cv::Mat luma(height, width, CV_8UC1, base, stride);
      if (gray) {
        luma.copyTo(*out);
        return {};
      }
      if (stride == w) {
        const cv::Mat src(height + height / 2, width, CV_8UC1, base);
        cv::cvtColor(src, *out, cv::COLOR_YUV2BGR_NV12);
      } else {
        const cv::Mat chroma(height / 2, width / 2, CV_8UC2, base + stride * h, stride);
        cv::cvtColorTwoPlane(luma, chroma, *out, cv::COLOR_YUV2BGR_NV12);
      }
      return {};
    }
    case PixelFormat::kBgr24:
    case PixelFormat::kRgb24: {
      const cv::Mat src(height, width, CV_8UC3, base, stride);
      if (gray) {
        cv::cvtColor(src, *out, format == PixelFormat::kBgr24 ? cv::COLOR_BGR2GRAY : cv::COLOR_RGB2GRAY);
      } else if (format == PixelFormat::kBgr24) {
        src.copyTo(*out);
      } else {
        cv::cvtColor(src, *out, cv::COLOR_RGB2BGR);
      }
      return {};
    }
    case PixelFormat::kMjpeg: break;
  }
  return "unsupported format";
}

void BgrToYuyv(const cv::Mat& bgr, std::string* out) {
  const int width = bgr.cols, height = bgr.rows;
  out->resize(static_cast<size_t>(width) * height * 2);
  auto* d = reinterpret_cast<uint8_t*>(out->data());
  auto clamp = [](int v) { return static_cast<uint8_t>(std::clamp(v, 0, 255)); };
  for (int y = 0; y < height; ++y) {
    const uint8_t* s = bgr.ptr<uint8_t>(y);
    for (int x = 0; x + 1 < width; x += 2) {
      int ys[2], us = 0, vs = 0;
      for (int k = 0; k < 2; ++k) {
        const int b = s[3 * (x + k)], g = s[3 * (x + k) + 1], r = s[3 * (x + k) + 2];
        ys[k] = ((66 * r + 129 * g + 25 * b + 128) >> 8) + 16;
        us += ((-38 * r - 74 * g + 112 * b + 128) >> 8) + 128;
        vs += ((112 * r - 94 * g - 18 * b + 128) >> 8) + 128;
      }
      d[0] = clamp(ys[0]);
      d[1] = clamp((us + 1) / 2);
      d[2] = clamp(ys[1]);
      d[3] = clamp((vs + 1) / 2);
      d += 4;
    }
  }
}

MjpegDecoder::MjpegDecoder() : handle_(tjInitDecompress()) {}
MjpegDecoder::~MjpegDecoder() {
  if (handle_) tjDestroy(static_cast<tjhandle>(handle_));
}

std::string MjpegDecoder::Decode(const uint8_t* data, size_t size, bool gray, cv::Mat* out) {
  if (!handle_) return "libjpeg-turbo: cannot create a decoder";
  auto* h = static_cast<tjhandle>(handle_);
  int width = 0, height = 0, subsamp = 0, colorspace = 0;
  if (tjDecompressHeader3(h, data, static_cast<unsigned long>(size), &width, &height, &subsamp,
                          &colorspace) != 0) {
    return std::string("MJPEG header: ") + tjGetErrorStr2(h);
  }
  out->create(height, width, gray ? CV_8UC1 : CV_8UC3);
  if (tjDecompress2(h, data, static_cast<unsigned long>(size), out->data, width,
                    static_cast<int>(out->step[0]), height, gray ? TJPF_GRAY : TJPF_BGR,
                    TJFLAG_FASTDCT) != 0) {
    // A warning (e.g. premature end of data, common on USB cameras) still yields an image.
    if (tjGetErrorCode(h) == TJERR_FATAL) return std::string("MJPEG decode: ") + tjGetErrorStr2(h);
  }
  return {};
}

std::string ConvertFrame(PixelFormat format, const uint8_t* data, size_t size, int width,
                         int height, size_t stride, bool gray, MjpegDecoder* decoder,
                         cv::Mat* out) {
  if (format == PixelFormat::kMjpeg) return decoder->Decode(data, size, gray, out);
  return ConvertRaw(format, data, size, width, height, stride, gray, out);
}

}  // namespace mm
