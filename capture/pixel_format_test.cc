// The pure parts of V4L2 capture: format conversion against OpenCV's cvtColor (with and
// without line padding), the YUYV encoder of the feeder, MJPEG decoding, fourcc names.

#include "capture/pixel_format.h"

#include <gtest/gtest.h>
#include <linux/videodev2.h>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <random>

#include "capture/loopback_feeder.h"

namespace mm {
namespace {

std::vector<uint8_t> RandomBytes(size_t n, uint32_t seed) {
  std::mt19937 rng(seed);
  std::vector<uint8_t> v(n);
  for (auto& b : v) b = static_cast<uint8_t>(rng());
  return v;
}

// Copies a tight buffer of `rows` lines of `line` bytes into one with `stride` bytes per line.
std::vector<uint8_t> Pad(const std::vector<uint8_t>& tight, size_t line, size_t rows, size_t stride) {
  std::vector<uint8_t> out(stride * rows, 0xAB);
  for (size_t r = 0; r < rows; ++r) std::copy_n(tight.data() + r * line, line, out.data() + r * stride);
  return out;
}

bool Same(const cv::Mat& a, const cv::Mat& b) {
  return a.size() == b.size() && a.type() == b.type() && cv::norm(a, b, cv::NORM_INF) == 0;
}

class ConvertTest : public ::testing::TestWithParam<size_t> {};  // Param: extra padding bytes.

TEST_P(ConvertTest, YuyvMatchesCvtColor) {
  const int w = 64, h = 48;
  const auto tight = RandomBytes(2 * w * h, 1);
  cv::Mat ref_bgr, ref_gray;
  const cv::Mat src(h, w, CV_8UC2, const_cast<uint8_t*>(tight.data()));
  cv::cvtColor(src, ref_bgr, cv::COLOR_YUV2BGR_YUYV);
  cv::cvtColor(src, ref_gray, cv::COLOR_YUV2GRAY_YUYV);
  const size_t stride = 2 * w + GetParam();
  const auto padded = Pad(tight, 2 * w, h, stride);
  cv::Mat bgr, gray;
  ASSERT_EQ(ConvertRaw(PixelFormat::kYuyv, padded.data(), padded.size(), w, h, stride, false, &bgr), "");
  ASSERT_EQ(ConvertRaw(PixelFormat::kYuyv, padded.data(), padded.size(), w, h, stride, true, &gray), "");
  EXPECT_TRUE(Same(bgr, ref_bgr));
  EXPECT_TRUE(Same(gray, ref_gray));
}

TEST_P(ConvertTest, Nv12MatchesCvtColor) {
  const int w = 64, h = 48;
  const auto tight = RandomBytes(w * h * 3 / 2, 2);
  cv::Mat ref_bgr, ref_gray;
  const cv::Mat src(h * 3 / 2, w, CV_8UC1, const_cast<uint8_t*>(tight.data()));
  cv::cvtColor(src, ref_bgr, cv::COLOR_YUV2BGR_NV12);
  cv::cvtColor(src, ref_gray, cv::COLOR_YUV2GRAY_NV12);
  const size_t stride = w + GetParam();
  const auto padded = Pad(tight, w, h * 3 / 2, stride);
  cv::Mat bgr, gray;
  ASSERT_EQ(ConvertRaw(PixelFormat::kNv12, padded.data(), padded.size(), w, h, stride, false, &bgr), "");
  ASSERT_EQ(ConvertRaw(PixelFormat::kNv12, padded.data(), padded.size(), w, h, stride, true, &gray), "");
  EXPECT_TRUE(Same(bgr, ref_bgr));
  EXPECT_TRUE(Same(gray, ref_gray));
}

TEST_P(ConvertTest, GreyCopiesAndExpands) {
  const int w = 30, h = 20;
  const auto tight = RandomBytes(w * h, 3);
  const size_t stride = w + GetParam();
  const auto padded = Pad(tight, w, h, stride);
  cv::Mat bgr, gray, ref_bgr;
  const cv::Mat ref(h, w, CV_8UC1, const_cast<uint8_t*>(tight.data()));
  cv::cvtColor(ref, ref_bgr, cv::COLOR_GRAY2BGR);
  ASSERT_EQ(ConvertRaw(PixelFormat::kGrey, padded.data(), padded.size(), w, h, stride, true, &gray), "");
  ASSERT_EQ(ConvertRaw(PixelFormat::kGrey, padded.data(), padded.size(), w, h, stride, false, &bgr), "");
  EXPECT_TRUE(Same(gray, ref));
  EXPECT_TRUE(Same(bgr, ref_bgr));
}

INSTANTIATE_TEST_SUITE_P(Strides, ConvertTest, ::testing::Values(0, 32));

TEST(ConvertRaw, ShortBufferAndBadStrideAreErrors) {
  std::vector<uint8_t> small(100);
  cv::Mat out;
  const std::string e = ConvertRaw(PixelFormat::kYuyv, small.data(), small.size(), 64, 48, 0, false, &out);
  EXPECT_NE(e.find("short frame: 100 bytes, 6144 expected for yuyv 64x48"), std::string::npos) << e;
  EXPECT_NE(ConvertRaw(PixelFormat::kGrey, small.data(), small.size(), 10, 5, 4, true, &out).find("stride"),
            std::string::npos);
}

TEST(BgrToYuyv, RoundTripIsClose) {
  cv::Mat bgr(32, 32, CV_8UC3);
  cv::randu(bgr, 0, 256);
  cv::GaussianBlur(bgr, bgr, cv::Size(7, 7), 2.0);  // Chroma subsampling needs smooth colour.
  std::string yuyv;
  BgrToYuyv(bgr, &yuyv);
  ASSERT_EQ(yuyv.size(), 32u * 32u * 2u);
  cv::Mat back;
  ASSERT_EQ(ConvertRaw(PixelFormat::kYuyv, reinterpret_cast<const uint8_t*>(yuyv.data()),
                       yuyv.size(), 32, 32, 0, false, &back), "");
  cv::Mat diff;
  cv::absdiff(bgr, back, diff);
  EXPECT_LT(cv::mean(diff)[0], 4.0);
  // Luma of the feeder agrees with OpenCV's limited-range conversion within rounding.
  cv::Mat gray_ref, yuv_ref;
  cv::Mat gray;
  ASSERT_EQ(ConvertRaw(PixelFormat::kYuyv, reinterpret_cast<const uint8_t*>(yuyv.data()),
                       yuyv.size(), 32, 32, 0, true, &gray), "");
  cv::cvtColor(bgr, yuv_ref, cv::COLOR_BGR2YUV_I420);
  const cv::Mat y_ref = yuv_ref.rowRange(0, 32);
  EXPECT_LE(cv::norm(gray, y_ref, cv::NORM_INF), 2.0);
}

TEST(EncodeForFeed, GreyIsOpenCvGrayAndMjpegIsRefused) {
  cv::Mat bgr(8, 8, CV_8UC3, cv::Scalar(10, 200, 30));
  std::string bytes;
  ASSERT_EQ(EncodeForFeed(bgr, PixelFormat::kGrey, &bytes), "");
  cv::Mat gray;
  cv::cvtColor(bgr, gray, cv::COLOR_BGR2GRAY);
  EXPECT_EQ(bytes, std::string(reinterpret_cast<const char*>(gray.data), 64));
  EXPECT_NE(EncodeForFeed(bgr, PixelFormat::kMjpeg, &bytes).find("cannot be fed"), std::string::npos);
}

TEST(MjpegDecoder, MatchesImdecode) {
  cv::Mat bgr(48, 64, CV_8UC3);
  cv::randu(bgr, 0, 256);
  std::vector<uint8_t> jpeg;
  ASSERT_TRUE(cv::imencode(".jpg", bgr, jpeg));
  MjpegDecoder decoder;
  cv::Mat out, gray;
  ASSERT_EQ(decoder.Decode(jpeg.data(), jpeg.size(), false, &out), "");
  ASSERT_EQ(decoder.Decode(jpeg.data(), jpeg.size(), true, &gray), "");
  const cv::Mat ref = cv::imdecode(jpeg, cv::IMREAD_COLOR);
  ASSERT_EQ(out.size(), ref.size());
  EXPECT_LE(cv::norm(out, ref, cv::NORM_INF), 8.0);  // FASTDCT vs ISLOW.
  EXPECT_EQ(gray.type(), CV_8UC1);
  cv::Mat via_frame;  // ConvertFrame sends MJPEG to the decoder.
  ASSERT_EQ(ConvertFrame(PixelFormat::kMjpeg, jpeg.data(), jpeg.size(), 64, 48, 0, false, &decoder,
                         &via_frame),
            "");
  EXPECT_TRUE(Same(via_frame, out));
  const std::vector<uint8_t> junk{1, 2, 3, 4};
  EXPECT_NE(decoder.Decode(junk.data(), junk.size(), false, &out).find("MJPEG"), std::string::npos);
}

// ConvertFrame sends the raw formats to ConvertRaw (MJPEG: MjpegDecoder.MatchesImdecode).
TEST(ConvertFrame, RawFormatsGoToConvertRaw) {
  MjpegDecoder decoder;
  const std::vector<uint8_t> grey = RandomBytes(64 * 48, 5);
  cv::Mat out;
  ASSERT_EQ(ConvertFrame(PixelFormat::kGrey, grey.data(), grey.size(), 64, 48, 0, true, &decoder, &out),
            "");
  EXPECT_TRUE(Same(out, cv::Mat(48, 64, CV_8UC1, const_cast<uint8_t*>(grey.data()))));
  EXPECT_NE(ConvertFrame(PixelFormat::kYuyv, grey.data(), 100, 64, 48, 0, false, &decoder, &out)
                .find("short frame"),
            std::string::npos);
}

TEST(Fourcc, NamesAndParsing) {
  EXPECT_EQ(FourccName(V4L2_PIX_FMT_YUYV), "YUYV");
  EXPECT_EQ(FourccName(V4L2_PIX_FMT_MJPEG), "MJPG");
  EXPECT_EQ(FromFourcc(V4L2_PIX_FMT_NV12), PixelFormat::kNv12);
  EXPECT_EQ(FromFourcc(V4L2_PIX_FMT_RGB565), std::nullopt);
  EXPECT_EQ(FromFourcc(V4L2_PIX_FMT_RGB24), PixelFormat::kRgb24);
  EXPECT_EQ(ParsePixelFormat("MJPEG"), PixelFormat::kMjpeg);
  EXPECT_EQ(ParsePixelFormat("gray"), PixelFormat::kGrey);
  EXPECT_EQ(ParsePixelFormat("rgb565"), std::nullopt);
  for (PixelFormat f : {PixelFormat::kGrey, PixelFormat::kYuyv, PixelFormat::kNv12, PixelFormat::kMjpeg,
                        PixelFormat::kBgr24, PixelFormat::kRgb24}) {
    EXPECT_EQ(FromFourcc(ToFourcc(f)), f);
    EXPECT_EQ(ParsePixelFormat(PixelFormatName(f)), f);
  }
}

}  // namespace
}  // namespace mm
