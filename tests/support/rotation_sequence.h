#pragma once
// A rotation-only "camera motion" for gate tests: frame i is `image` warped by the homography
// K R_i K^-1 of a camera turning 0.3 deg/frame in yaw and 0.1 deg/frame in pitch (plus
// `roll_per_frame_deg`), i.e. up to ~90 px of image motion over 30 frames and no parallax.

#include <Eigen/Geometry>
#include <cmath>
#include <opencv2/imgproc.hpp>
#include <vector>

namespace mm::test {

inline std::vector<cv::Mat> RotationOnlySequence(const cv::Mat& image, const Eigen::Matrix3d& K,
                                                 int frames, double roll_per_frame_deg = 0.0) {
  std::vector<cv::Mat> out{image};
  const double deg = M_PI / 180.0;
  for (int i = 1; i <= frames; ++i) {
    const Eigen::Matrix3d r = (Eigen::AngleAxisd(0.3 * i * deg, Eigen::Vector3d::UnitY()) *
                               Eigen::AngleAxisd(0.1 * i * deg, Eigen::Vector3d::UnitX()) *
                               Eigen::AngleAxisd(roll_per_frame_deg * i * deg,
                                                 Eigen::Vector3d::UnitZ()))
                                  .toRotationMatrix();
    const Eigen::Matrix3d h = K * r * K.inverse();
    cv::Mat h_cv(3, 3, CV_64F);
    for (int y = 0; y < 3; ++y) {
      for (int x = 0; x < 3; ++x) h_cv.at<double>(y, x) = h(y, x);
    }
    cv::Mat warped;
    cv::warpPerspective(image, warped, h_cv, image.size(), cv::INTER_LINEAR, cv::BORDER_REFLECT);
    out.push_back(warped);
  }
  return out;
}

}  // namespace mm::test
