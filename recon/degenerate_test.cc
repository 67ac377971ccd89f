// Degenerate input is reported, not reconstructed (issue 4): a pure-rotation warp, identical
// images, and the hard ScanNet wide-baseline pairs (succeed within 5 deg or fail with a reason).

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <fstream>
#include <opencv2/core/eigen.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <sstream>

#include "dataset/tum.h"
#include "recon/pipeline.h"
#include "calib/calib_io.h"
#include "tests/support/shared_data.h"

namespace mm {
namespace {

// TUM's published fr3 intrinsics, from the bundled calibration (one source of truth).
BouguetCamera TumCamera() {
  return LoadCalibration(std::filesystem::path(MM_SOURCE_DIR) / "data/tum_office/calib.toml");
}

cv::Mat TumKeyframe(const char* name) {
  const auto dir =
      test::RequireSharedData("tum_fr3_long_office_household") / "keyframes_1hz";
  return cv::imread((dir / name).string(), cv::IMREAD_COLOR);
}

TEST(Degenerate, PureRotationWarpIsClassifiedAsRotation) {
  const cv::Mat a = TumKeyframe("1341847980.722988.png");
  ASSERT_FALSE(a.empty());
  const BouguetCamera camera = TumCamera();
  const Eigen::Matrix3d k = camera.K();
  // 4 deg pan and 2 deg tilt: H = K R K^-1 maps A's pixels to the rotated camera's.
  const Eigen::Matrix3d r = (Eigen::AngleAxisd(4.0 * M_PI / 180, Eigen::Vector3d::UnitY()) *
                             Eigen::AngleAxisd(2.0 * M_PI / 180, Eigen::Vector3d::UnitX()))
                                .toRotationMatrix();
  const Eigen::Matrix3d h = k * r * k.inverse();
  cv::Mat h_cv, b;
  cv::eigen2cv(h, h_cv);
  cv::warpPerspective(a, b, h_cv, a.size(), cv::INTER_LINEAR);
  const PairReconstruction result = ReconstructPair(a, b, camera, PairOptions{});
  EXPECT_FALSE(result.success);
  EXPECT_EQ(result.geometry.classification.kind, PairKind::kRotation)
      << result.failure_reason << " h_share " << result.geometry.classification.h_share
      << " dev " << result.geometry.classification.rotation_deviation;
  EXPECT_NE(result.failure_reason.find("rotation"), std::string::npos) << result.failure_reason;
}

TEST(Degenerate, IdenticalImagesHaveNoParallax) {
  const cv::Mat a = TumKeyframe("1341847980.722988.png");
  ASSERT_FALSE(a.empty());
  const PairReconstruction result = ReconstructPair(a, a.clone(), TumCamera(), PairOptions{});
  EXPECT_FALSE(result.success);
  EXPECT_EQ(result.geometry.classification.kind, PairKind::kNoParallax) << result.failure_reason;
  EXPECT_NE(result.failure_reason.find("parallax"), std::string::npos) << result.failure_reason;
}

TEST(Degenerate, ScanNetPairsSucceedAccuratelyOrFailWithReason) {
  const auto dir = test::RequireSharedData("scannet_pairs_superglue");
  std::ifstream list(dir / "scannet_sample_pairs_with_gt.txt");
  ASSERT_TRUE(list.good());
  std::string line;
  int pairs = 0, succeeded = 0;
  while (std::getline(list, line)) {
    std::istringstream in(line);
    std::string name_a, name_b;
    int rot_a = 0, rot_b = 0;
    if (!(in >> name_a >> name_b >> rot_a >> rot_b)) continue;
    double ka[9], kb[9], t[16];
    for (double& v : ka) in >> v;
    for (double& v : kb) in >> v;
    for (double& v : t) in >> v;
    ASSERT_TRUE(in) << line;
    const cv::Mat a = cv::imread((dir / "images" / name_a).string(), cv::IMREAD_COLOR);
    const cv::Mat b = cv::imread((dir / "images" / name_b).string(), cv::IMREAD_COLOR);
    ASSERT_FALSE(a.empty() || b.empty()) << name_a;
    BouguetCamera camera;
    camera.width = a.cols;
    camera.height = a.rows;
    camera.fc = {ka[0], ka[4]};
    camera.cc = {ka[2], ka[5]};
    const PairReconstruction r = ReconstructPair(a, b, camera, PairOptions{});
    ++pairs;
    Eigen::Matrix3d r_gt;
    r_gt << t[0], t[1], t[2], t[4], t[5], t[6], t[8], t[9], t[10];
    const double rot_err = RotationErrorDeg(r.geometry.rotation, r_gt);
    std::cout << name_a << " " << name_b << ": "
              << (r.success ? "ok, rotation error " + std::to_string(rot_err) + " deg"
                            : "failed: " + r.failure_reason)
              << "\n";
    if (r.success) {
      ++succeeded;
      EXPECT_LT(rot_err, 5.0) << name_a << " " << name_b;
    } else {
      EXPECT_FALSE(r.failure_reason.empty()) << name_a;
    }
  }
  EXPECT_EQ(pairs, 15);
  std::cout << succeeded << " of " << pairs << " ScanNet pairs succeeded\n";
}

}  // namespace
}  // namespace mm
