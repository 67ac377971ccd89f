// V4L2 without a device: URI parsing, option checks and the error texts for missing devices,
// non-V4L2 files and unsupported formats. (Real devices: tests/kernel.)

#include "capture/v4l2_source.h"

#include <gtest/gtest.h>
#include <linux/videodev2.h>

#include "capture/source_uri.h"

namespace mm {
namespace {

TEST(V4l2Uri, ParsesEveryParameter) {
  const V4l2Options o = ParseV4l2Uri(
      "v4l2:/dev/video3?width=1280&height=720&fps=30&format=mjpeg&gray=1&exposure=100&gain=8&"
      "buffers=6&timeout_ms=500");
  EXPECT_EQ(o.device, "/dev/video3");
  EXPECT_EQ(o.width, 1280);
  EXPECT_EQ(o.height, 720);
  EXPECT_DOUBLE_EQ(o.fps, 30.0);
  EXPECT_EQ(o.format, PixelFormat::kMjpeg);
  EXPECT_TRUE(o.gray);
  EXPECT_EQ(o.exposure, 100);
  EXPECT_EQ(o.gain, 8);
  EXPECT_EQ(o.buffers, 6);
  EXPECT_EQ(o.lost_after_ms, 500);
  EXPECT_EQ(o.Check(), "");
  const V4l2Options d = ParseV4l2Uri("v4l2:/dev/video0");
  EXPECT_EQ(d.width, 0);
  EXPECT_FALSE(d.format.has_value());
}

std::string UriError(const std::string& uri) {
  try {
    CreateFrameSource(uri);
  } catch (const SourceUriError& e) {
    return e.what();
  }
  return "";
}

TEST(V4l2Uri, BadUrisNameTheProblem) {
  EXPECT_NE(UriError("v4l2:/dev/video0?format=rgb565").find("format=rgb565 is not supported (supported: grey, yuyv, nv12, mjpeg, bgr24, rgb24)"),
            std::string::npos);
  EXPECT_NE(UriError("v4l2:/dev/video0?width=640").find("give both width and height"),
            std::string::npos);
  EXPECT_NE(UriError("v4l2:/dev/video0?fps=fast").find("fps=fast"), std::string::npos);
  EXPECT_NE(UriError("v4l2:/dev/video0?zoom=2").find("unknown parameter 'zoom'"), std::string::npos);
  EXPECT_NE(UriError("v4l2:").find("needs a device"), std::string::npos);
  EXPECT_NE(UriError("usb:/dev/video0").find("unknown scheme 'usb'"), std::string::npos);
}

TEST(V4l2Source, MissingDeviceIsNamed) {
  V4l2Source source(ParseV4l2Uri("v4l2:/dev/video-does-not-exist"));
  EXPECT_EQ(source.Open(), "v4l2 /dev/video-does-not-exist: no such device (is the camera plugged in?)");
  Frame f;
  std::string error;
  EXPECT_EQ(source.Read(&f, std::chrono::milliseconds(1), &error), ReadStatus::kError);
  EXPECT_NE(error.find("before Open"), std::string::npos);
}

TEST(V4l2Source, NonV4l2FileIsNamed) {
  V4l2Source source(ParseV4l2Uri("v4l2:/dev/null"));
  const std::string e = source.Open();
  EXPECT_NE(e.find("v4l2 /dev/null: not a V4L2 device"), std::string::npos) << e;
}

TEST(V4l2Source, OptionsAreChecked) {
  V4l2Options o;
  EXPECT_NE(o.Check(), "");
  o.device = "/dev/video0";
  EXPECT_EQ(o.Check(), "");
  o.buffers = 1;
  EXPECT_NE(o.Check().find("buffers"), std::string::npos);
}

TEST(DescribeOffers, ListsFormatsSizesAndRates) {
  V4l2FormatOffer yuyv;
  yuyv.fourcc = V4L2_PIX_FMT_YUYV;
  yuyv.sizes = {{640, 480, {30, 15}}, {1280, 720, {10}}};
  V4l2FormatOffer rgb;
  rgb.fourcc = V4L2_PIX_FMT_RGB565;
  rgb.stepwise = "16x16-1920x1080 step 2x2";
  EXPECT_EQ(DescribeOffers({yuyv, rgb}),
            "YUYV 640x480@15-30fps, 1280x720@10fps; not convertible: RGBP");
  EXPECT_EQ(DescribeOffers({}), "no capture formats");
}

}  // namespace
}  // namespace mm

namespace mm {
namespace {

TEST(LibcameraUri, MissingCameraIsNamedWithTheList) {
  EXPECT_NE(UriError("libcamera:").find("needs a camera id or index"), std::string::npos);
  EXPECT_NE(UriError("libcamera:0?zoom=1").find("unknown parameter 'zoom'"), std::string::npos);
  auto source = CreateFrameSource("libcamera:no-such-camera?width=640&height=480");
  const std::string e = source->Open();
  EXPECT_NE(e.find("libcamera no-such-camera: no such camera (libcamera lists: "), std::string::npos) << e;
}

}  // namespace
}  // namespace mm
