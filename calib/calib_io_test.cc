#include "calib/calib_io.h"

#include <gtest/gtest.h>

namespace mm {
namespace {

void ExpectErrorMentions(const std::string& text, const std::string& needle) {
  try {
    ParseCalibrationToml(text, "cam.toml");
    FAIL() << "expected CalibrationError for: " << text;
  } catch (const CalibrationError& e) {
    EXPECT_NE(std::string(e.what()).find(needle), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("cam.toml"), std::string::npos) << e.what();
  }
}

constexpr const char* kGood = R"([camera]
image_size = [640, 480]
fc = [535.4, 539.2]
cc = [320.1, 247.6]
alpha_c = 0.001
kc = [0.1, -0.2, 0.001, 0.002]
)";

TEST(CalibIo, ParsesStoredFormatWithFourKc) {
  const BouguetCamera c = ParseCalibrationToml(kGood, "cam.toml");
  EXPECT_EQ(c.width, 640);
  EXPECT_DOUBLE_EQ(c.fc.y(), 539.2);
  EXPECT_DOUBLE_EQ(c.alpha_c, 0.001);
  EXPECT_DOUBLE_EQ(c.kc[3], 0.002);
  EXPECT_DOUBLE_EQ(c.kc[4], 0.0);
  EXPECT_FALSE(c.error.has_value());
}

TEST(CalibIo, RoundTripsExactly) {
  BouguetCamera c = ParseCalibrationToml(kGood, "cam.toml");
  c.fc.x() = 657.46329871743;
  BouguetCamera::Uncertainty e;
  e.fc = {0.31, 0.33};
  e.kc = {0.01, 0.02, 0.001, 0.001, 0};
  c.error = e;
  const BouguetCamera back = ParseCalibrationToml(FormatCalibrationToml(c), "x");
  EXPECT_EQ(back.fc, c.fc);
  EXPECT_EQ(back.cc, c.cc);
  EXPECT_EQ(back.kc, c.kc);
  EXPECT_EQ(back.alpha_c, c.alpha_c);
  ASSERT_TRUE(back.error.has_value());
  EXPECT_EQ(back.error->fc, e.fc);
  EXPECT_EQ(back.error->kc, e.kc);
}

TEST(CalibIo, ErrorsNameTheField) {
  ExpectErrorMentions("[camera]\nimage_size=[640,480]\ncc=[1,2]\nkc=[0,0,0,0]\n", "camera.fc");
  ExpectErrorMentions("[camera]\nimage_size=[640,480]\nfc=[1,2,3]\ncc=[1,2]\nkc=[0,0,0,0]\n",
                      "expected 2 values, got 3");
  ExpectErrorMentions("[camera]\nimage_size=[640,480]\nfc=[-5,2]\ncc=[1,2]\nkc=[0,0,0,0]\n",
                      "camera.fc");
  ExpectErrorMentions("[camera]\nimage_size=[640,480]\nfc=[nan,2]\ncc=[1,2]\nkc=[0,0,0,0]\n",
                      "camera.fc");
  ExpectErrorMentions("[camera]\nfc=[1,2]\ncc=[1,2]\nkc=[0,0,0,0]\n", "camera.image_size");
  ExpectErrorMentions("[camera]\nimage_size=[640,480]\nfc=[1,2]\ncc=[1,2]\nkc=[0,0]\n",
                      "camera.kc");
  ExpectErrorMentions("fc = [", "not valid TOML");
  ExpectErrorMentions("[other]\n", "[camera]");
}

// A distortion the undistortion cannot invert over the image (here a strong barrel term that
// folds back before the corners) is refused at load, naming camera.kc and a pixel; a wide but
// regular lens loads.
TEST(CalibIo, DistortionThatDoesNotInvertOverTheImageNamesKc) {
  const std::string head = "[camera]\nimage_size = [640, 480]\nfc = [300, 300]\ncc = [320, 240]\n";
  ExpectErrorMentions(head + "kc = [-0.8, 0, 0, 0]\n", "camera.kc");
  ExpectErrorMentions(head + "kc = [-0.8, 0, 0, 0]\n", "not invertible over the 640x480 image");
  ExpectErrorMentions(head + "kc = [0.5, -0.6, 0, 0]\n", "camera.kc");  // Folds at r = 0.94.
  const BouguetCamera wide = ParseCalibrationToml(head + "kc = [-0.3, 0.09, 0.001, 0.001]\n", "w");
  EXPECT_TRUE(wide.CheckInvertible().empty());
}

// A monotonic distortion that inverts but squeezes the image into a few pixels (all of kc at
// 1e6, the range's end) is refused too, naming kc and why; a strong pincushion loads.
TEST(CalibIo, DistortionThatSqueezesTheImageNamesKc) {
  const std::string head =
      "[camera]\nimage_size = [640, 480]\nfc = [535.4, 539.2]\ncc = [320.1, 247.6]\n";
  ExpectErrorMentions(head + "kc = [1e6, 1e6, 0, 0, 1e6]\n", "field 'camera.kc'");
  ExpectErrorMentions(head + "kc = [1e6, 1e6, 0, 0, 1e6]\n",
                      "times as far from the principal point undistorted (at most 4");
  ExpectErrorMentions(head + "kc = [0, 0, 0, 0, 1e6]\n", "camera.kc");
  EXPECT_TRUE(ParseCalibrationToml(head + "kc = [0.4, 0.2, 0, 0, 0.1]\n", "p").Check().empty());
}

// Every number through one checked conversion: image sizes that would make OpenCV throw (or
// wrap through a cast to int), non-finite and absurd values are errors naming the field.
TEST(CalibIo, NumbersOutOfRangeNameTheField) {
  const std::string rest = "fc=[500,500]\ncc=[320,240]\nkc=[0,0,0,0]\n";
  ExpectErrorMentions("[camera]\nimage_size=[1000000,1000000]\n" + rest,
                      "field 'camera.image_size': expected an integer in [1, 16384]");
  ExpectErrorMentions("[camera]\nimage_size=[4294967936,480]\n" + rest, "camera.image_size");
  ExpectErrorMentions("[camera]\nimage_size=[640.5,480]\n" + rest, "camera.image_size");
  ExpectErrorMentions("[camera]\nimage_size=[0,480]\n" + rest, "camera.image_size");
  ExpectErrorMentions(
      "[camera]\nimage_size=[640,480]\nfc=[inf,500]\ncc=[320,240]\n"
      "kc=[0,0,0,0]\n",
      "camera.fc");
  ExpectErrorMentions(
      "[camera]\nimage_size=[640,480]\nfc=[500,500]\ncc=[1e300,240]\n"
      "kc=[0,0,0,0]\n",
      "camera.cc");
  ExpectErrorMentions("[camera]\nimage_size=[640,480]\n" + rest + "alpha_c = nan\n",
                      "camera.alpha_c");
  ExpectErrorMentions(
      "[camera]\nimage_size=[640,480]\nfc=[500,500]\ncc=[320,240]\n"
      "kc=[0,0,-inf,0]\n",
      "camera.kc");
  ExpectErrorMentions("[camera]\nimage_size=[640,480]\n" + rest +
                          "[camera.error]\nfc=[1,1]\ncc=[1,1]\nkc=[0,0,0,nan]\n",
                      "camera.error.kc");
  ExpectErrorMentions("[camera]\nimage_size=[640,\"480\"]\n" + rest, "wrong type");
  EXPECT_EQ(ParseCalibrationToml("[camera]\nimage_size=[16384,16384]\n" + rest, "cam.toml").width,
            16384);
}

TEST(CalibIo, MissingFileNamesPath) {
  try {
    LoadCalibration("/nonexistent/calib.toml");
    FAIL();
  } catch (const CalibrationError& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent/calib.toml"), std::string::npos);
  }
}

}  // namespace
}  // namespace mm
