#pragma once
// Pixel formats a camera may deliver and their conversion to the pipeline's BGR8 / GRAY8.
// Pure functions over raw buffers (with the driver's line stride), tested against OpenCV.

#include <cstddef>
#include <cstdint>
#include <memory>
#include <opencv2/core.hpp>
#include <optional>
#include <string>

namespace mm {

/// The formats mm_capture understands.
enum class PixelFormat {
  kGrey,
  kYuyv,
  kNv12,
  kMjpeg,
  kBgr24,  ///< Packed, bytes B,G,R (V4L2 BGR3; libcamera RGB888).
  kRgb24,  ///< Packed, bytes R,G,B (V4L2 RGB3; libcamera BGR888).
};

/// The V4L2 fourcc of a format.
uint32_t ToFourcc(PixelFormat format);
/// The format of a V4L2 fourcc, or nullopt when mm_capture cannot convert it.
std::optional<PixelFormat> FromFourcc(uint32_t fourcc);
/// "GREY", "YUYV", "NV12", "MJPG", or the fourcc's four characters for any other code.
std::string FourccName(uint32_t fourcc);
/// Lower-case URI name: grey, yuyv, nv12, mjpeg, bgr24, rgb24.
std::string PixelFormatName(PixelFormat format);
/// Parses grey|gray|yuyv|nv12|mjpeg|mjpg|bgr24|rgb24 (case-insensitive).
std::optional<PixelFormat> ParsePixelFormat(const std::string& name);

/// Bytes of one frame in `format` at the tightest stride (MJPEG: 0, its size varies).
size_t FrameBytes(PixelFormat format, int width, int height);

/// Converts one raw frame to GRAY8 (`gray` true) or BGR8. `stride` is bytes per line of the
/// (first) plane as the driver reports it (0: tight). Returns an error message, empty on success.
/// For NV12 the chroma plane follows the luma plane at `stride * height`.
std::string ConvertRaw(PixelFormat format, const uint8_t* data, size_t size, int width, int height,
                       size_t stride, bool gray, cv::Mat* out);

/// BGR8 -> packed YUYV (BT.601 limited range, the inverse of OpenCV's COLOR_YUV2BGR_YUYV);
/// `width` must be even. Used by the loopback feeder.
void BgrToYuyv(const cv::Mat& bgr, std::string* out);

/// A reusable libjpeg-turbo decoder (one per thread). RAII over the tjhandle.
class MjpegDecoder {
 public:
  MjpegDecoder();
  ~MjpegDecoder();
  MjpegDecoder(const MjpegDecoder&) = delete;
  MjpegDecoder& operator=(const MjpegDecoder&) = delete;

  /// Decodes a JPEG (camera MJPEG frames without Huffman tables included) into BGR8 or GRAY8,
  /// reusing `out`'s memory when the size matches. Returns an error message, empty on success.
  [[nodiscard]] std::string Decode(const uint8_t* data, size_t size, bool gray, cv::Mat* out);

 private:
  void* handle_ = nullptr;
};

/// One camera frame of any supported format to GRAY8 / BGR8: MJPEG through `decoder` (`size`
/// = the JPEG's bytes), the raw formats through ConvertRaw. Returns an error message, empty on
/// success.
std::string ConvertFrame(PixelFormat format, const uint8_t* data, size_t size, int width,
                         int height, size_t stride, bool gray, MjpegDecoder* decoder,
                         cv::Mat* out);

}  // namespace mm
