// The capture session on real frames: the bundled TUM keyframes (about 1 s apart) for the
// policy (B tries, refusals, timeout, lost track), and the SUN3D study room (real 30 Hz
// hand-held video) for the agreement of the gate and the reconstruction.
#include "session/capture_session.h"

#include <gtest/gtest.h>

#include <opencv2/imgcodecs.hpp>

#include "calib/calib_io.h"
#include "dataset/tum.h"
#include "tests/support/shared_data.h"

namespace mm {
namespace {

const std::filesystem::path kBundled = std::filesystem::path(MM_SOURCE_DIR) / "data/tum_office";

cv::Mat Gray(const std::filesystem::path& p) {
  return cv::imread(p.string(), cv::IMREAD_GRAYSCALE);
}

struct Bundled {
  Eigen::Matrix3d K = LoadCalibration(kBundled / "calib.toml").K();
  std::vector<cv::Mat> frames;
  Bundled() {
    for (const TumFrame& f : ReadTumList(kBundled / "rgb.txt")) frames.push_back(Gray(f.path));
  }
};

using Step = CaptureSession::Step;

TEST(CaptureSession, RefusalThatMotionCuresKeepsTrackingAndAsksForMoreParallax) {
  const Bundled data;
  CaptureSession session(data.K, {});
  ASSERT_GT(session.Start(data.frames[0], 0.0), 100);
  ASSERT_EQ(session.OnFrame(data.frames[1], 1, 1.0, true), Step::kSubmitB);
  EXPECT_TRUE(session.b_in_flight());
  const double first = session.tries().back().gate_parallax_deg;
  EXPECT_GE(first, KeyframeGateOptions{}.parallax_deg);
  EXPECT_FALSE(session.Tracks().empty());
  // While the B is reconstructed the gate keeps tracking but hands over nothing.
  EXPECT_EQ(session.OnFrame(data.frames[2], 2, 2.0, false), Step::kWait);
  EXPECT_EQ(session.OnResult(false, TwoViewFailure::kNoParallax, "too little parallax"),
            Step::kWait);
  EXPECT_TRUE(session.open());
  ASSERT_EQ(session.tries().size(), 1u);
  EXPECT_FALSE(session.tries()[0].accepted);
  EXPECT_EQ(session.tries()[0].reason, "too little parallax");
  // The next B: a later frame, with more parallax than the refused one (growth 1.25).
  Step step = Step::kWait;
  size_t i = 3;
  for (; i < data.frames.size() && step == Step::kWait; ++i) {
    step = session.OnFrame(data.frames[i], i, static_cast<double>(i), true);
  }
  ASSERT_EQ(step, Step::kSubmitB) << session.failure_reason();
  EXPECT_GE(session.tries().back().gate_parallax_deg, 1.25 * first);
  EXPECT_EQ(session.OnResult(true, TwoViewFailure::kNone, {}), Step::kDone);
  EXPECT_FALSE(session.open());
  EXPECT_EQ(session.tries().size(), 2u);
  EXPECT_TRUE(session.tries().back().accepted);
}

TEST(CaptureSession, RefusalThatMotionCannotCureEndsTheCapture) {
  const Bundled data;
  CaptureSession session(data.K, {});
  session.Start(data.frames[0], 0.0);
  ASSERT_EQ(session.OnFrame(data.frames[1], 1, 1.0, true), Step::kSubmitB);
  EXPECT_EQ(session.OnResult(false, TwoViewFailure::kTooFewMatches, "too few matches (9)"),
            Step::kFailed);
  EXPECT_EQ(session.failure_reason(), "too few matches (9)");
  EXPECT_FALSE(session.open());
}

TEST(CaptureSession, TimeoutWithoutBEndsWithNotEnoughMotion) {
  const Bundled data;
  CaptureSessionOptions options;
  options.timeout_s = 0.5;
  CaptureSession session(data.K, options);
  session.Start(data.frames[0], 10.0);
  EXPECT_EQ(session.OnTime(10.4), Step::kWait);
  EXPECT_EQ(session.OnTime(10.6), Step::kFailed);
  EXPECT_EQ(session.failure_reason().rfind("not enough motion", 0), 0u) << session.failure_reason();
  // No frame came after A (a replay that ended): the reason says so, not an empty clause.
  EXPECT_NE(session.failure_reason().find("no frame after A reached the gate)"), std::string::npos)
      << session.failure_reason();
}

TEST(CaptureSession, TimeoutWaitsForTheBInFlight) {
  const Bundled data;
  CaptureSessionOptions options;
  options.timeout_s = 1.5;
  CaptureSession session(data.K, options);
  session.Start(data.frames[0], 0.0);
  ASSERT_EQ(session.OnFrame(data.frames[1], 1, 1.0, true), Step::kSubmitB);
  EXPECT_EQ(session.OnTime(5.0), Step::kWait);  // The result decides.
  EXPECT_EQ(session.OnResult(false, TwoViewFailure::kPlanar, "planar scene"), Step::kWait);
  EXPECT_EQ(session.OnFrame(data.frames[2], 2, 5.1, true), Step::kFailed);
  EXPECT_NE(session.failure_reason().find("1 B refused: planar x1"), std::string::npos)
      << session.failure_reason();
}

TEST(CaptureSession, MaxTriesEndsTheCapture) {
  const Bundled data;
  CaptureSessionOptions options;
  options.max_tries = 1;
  CaptureSession session(data.K, options);
  session.Start(data.frames[0], 0.0);
  ASSERT_EQ(session.OnFrame(data.frames[1], 1, 1.0, true), Step::kSubmitB);
  EXPECT_EQ(session.OnResult(false, TwoViewFailure::kCheirality, "no clear winner"), Step::kFailed);
  EXPECT_EQ(session.failure_reason().rfind("no accepted keyframe B after 1 B refused", 0), 0u)
      << session.failure_reason();
}

TEST(CaptureSession, LostTrackWhileBInFlightWaitsForItsResult) {
  const Bundled data;
  CaptureSession session(data.K, {});
  session.Start(data.frames[0], 0.0);
  ASSERT_EQ(session.OnFrame(data.frames[1], 1, 1.0, true), Step::kSubmitB);
  const cv::Mat blank(data.frames[0].size(), CV_8UC1, cv::Scalar(128));
  EXPECT_EQ(session.OnFrame(blank, 2, 1.1, false), Step::kWait);  // No track survives.
  EXPECT_TRUE(session.open());
  EXPECT_EQ(session.OnResult(true, TwoViewFailure::kNone, {}), Step::kDone);  // B still counts.

  session.Start(data.frames[0], 0.0);
  ASSERT_EQ(session.OnFrame(data.frames[1], 1, 1.0, true), Step::kSubmitB);
  EXPECT_EQ(session.OnFrame(blank, 2, 1.1, false), Step::kWait);
  EXPECT_EQ(session.OnResult(false, TwoViewFailure::kNoParallax, "too little parallax"),
            Step::kFailed);
  EXPECT_EQ(session.failure_reason().rfind("lost track (", 0), 0u) << session.failure_reason();
  EXPECT_NE(session.failure_reason().find("after 1 B refused: no_parallax x1"), std::string::npos)
      << session.failure_reason();
}

// A jump the tracks cannot follow (dropped frames): the frame that broke them goes to the
// reconstruction as a last B; the capture is lost only when that B is refused too, and never
// when the reconstruction is busy or the option is off.
TEST(CaptureSession, LostTrackHandsTheBreakingFrameToTheReconstruction) {
  const Bundled data;
  const cv::Mat blank(data.frames[0].size(), CV_8UC1, cv::Scalar(128));
  CaptureSession session(data.K, {});
  session.Start(data.frames[0], 0.0);
  ASSERT_EQ(session.OnFrame(blank, 7, 0.5, true), Step::kSubmitB);
  ASSERT_EQ(session.tries().size(), 1u);
  EXPECT_TRUE(session.tries()[0].after_lost_track);
  EXPECT_EQ(session.tries()[0].frame_sequence, 7u);
  EXPECT_EQ(session.OnFrame(data.frames[1], 8, 0.6, true), Step::kWait);  // Only the result now.
  EXPECT_EQ(session.OnResult(true, TwoViewFailure::kNone, {}), Step::kDone);

  session.Start(data.frames[0], 0.0);
  ASSERT_EQ(session.OnFrame(blank, 7, 0.5, true), Step::kSubmitB);
  // Even a refusal more motion could cure ends it: there are no tracks left to wait on.
  EXPECT_EQ(session.OnResult(false, TwoViewFailure::kNoParallax, "too little parallax"),
            Step::kFailed);
  EXPECT_EQ(session.end(), CaptureEnd::kLostTrack);
  EXPECT_EQ(session.failure_reason().rfind("lost track (", 0), 0u) << session.failure_reason();

  session.Start(data.frames[0], 0.0);
  EXPECT_EQ(session.OnFrame(blank, 7, 0.5, false), Step::kFailed);  // Reconstruction busy.
  EXPECT_EQ(session.end(), CaptureEnd::kLostTrack);

  CaptureSessionOptions off;
  off.b_after_lost_track = false;
  CaptureSession strict(data.K, off);
  strict.Start(data.frames[0], 0.0);
  EXPECT_EQ(strict.OnFrame(blank, 7, 0.5, true), Step::kFailed);
  EXPECT_TRUE(strict.tries().empty());
}

// One notion of "enough parallax": on real hand-held video the B the gate takes is one the
// reconstruction accepts, and the gate's tracks add inliers to the SIFT matches.
TEST(CaptureSession, GateBOnRealVideoIsAcceptedByTheReconstruction) {
  const auto dir = test::RequireSharedData("sun3d_studyroom_continuous");
  const BouguetCamera camera = LoadCalibration(dir / "Calib_Results.m");
  const std::vector<TumFrame> list = ReadTumList(dir / "rgb.txt");
  CaptureSession session(camera.K(), {});
  const cv::Mat a = cv::imread(list[0].path.string(), cv::IMREAD_COLOR);
  session.Start(Gray(list[0].path), list[0].timestamp_s);
  size_t b = 0;
  for (size_t i = 1; i < list.size() && b == 0; ++i) {
    if (session.OnFrame(Gray(list[i].path), i, list[i].timestamp_s, true) == Step::kSubmitB) b = i;
  }
  ASSERT_GT(b, 0u) << "the gate took no B in " << list.size() << " frames";
  const cv::Mat image_b = cv::imread(list[b].path.string(), cv::IMREAD_COLOR);
  const PairOptions options;
  const Features features_a = ExtractKeyframeFeatures(a, options);
  const std::vector<TrackCorrespondence> tracks = session.Tracks();
  const PairReconstruction with_tracks =
      ReconstructPair(features_a, a, image_b, camera, options, tracks);
  const PairReconstruction sift_only = ReconstructPair(features_a, a, image_b, camera, options);
  std::cout << "B = frame " << b << ", gate parallax " << session.tries().back().gate_parallax_deg
            << " deg; SIFT alone: " << sift_only.geometry.num_inliers << " inliers, angle "
            << sift_only.geometry.median_triangulation_angle_deg << " deg ("
            << sift_only.failure_reason << "); with " << with_tracks.tracks_used
            << " tracks: " << with_tracks.geometry.num_inliers << " inliers ("
            << with_tracks.track_inliers << " from tracks), angle "
            << with_tracks.geometry.median_triangulation_angle_deg << " deg ("
            << with_tracks.failure_reason << ")\n";
  EXPECT_TRUE(with_tracks.success) << with_tracks.failure_reason;
  EXPECT_GT(with_tracks.track_inliers, 0);
  EXPECT_GT(with_tracks.geometry.num_inliers, sift_only.geometry.num_inliers);
}

}  // namespace
}  // namespace mm
