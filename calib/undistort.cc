#include "calib/undistort.h"

#include <opencv2/imgproc.hpp>
#include <stdexcept>

namespace mm {

Undistorter::Undistorter(const BouguetCamera& camera)
    : input_(camera), output_(camera.Undistorted()) {
  if (camera.width <= 0 || camera.height <= 0) {
    throw std::invalid_argument("Undistorter: calibration has no image size");
  }
  if (!camera.HasDistortion()) return;
  cv::Mat map_x(camera.height, camera.width, CV_32FC1);
  cv::Mat map_y(camera.height, camera.width, CV_32FC1);
  for (int v = 0; v < camera.height; ++v) {
    auto* mx = map_x.ptr<float>(v);
    auto* my = map_y.ptr<float>(v);
    for (int u = 0; u < camera.width; ++u) {
      // Output pixel -> normalized ray (output camera keeps KK) -> distorted pixel.
      const Eigen::Vector2d x_n = output_.DistortedFromPixel({u, v});
      const Eigen::Vector2d src = input_.PixelFromDistorted(input_.Distort(x_n));
      mx[u] = static_cast<float>(src.x());
      my[u] = static_cast<float>(src.y());
    }
  }
  cv::convertMaps(map_x, map_y, map_xy_, map_frac_, CV_16SC2);
}

std::vector<cv::Point2f> Undistorter::UndistortPoints(
    const std::vector<cv::Point2f>& distorted) const {
  std::vector<cv::Point2f> out;
  out.reserve(distorted.size());
  for (const cv::Point2f& p : distorted) {
    const Eigen::Vector2d x_n = input_.Unproject({p.x, p.y});
    const Eigen::Vector2d q = output_.PixelFromDistorted(x_n);
    out.emplace_back(static_cast<float>(q.x()), static_cast<float>(q.y()));
  }
  return out;
}

cv::Mat Undistorter::Apply(const cv::Mat& distorted) const {
  if (distorted.cols != input_.width || distorted.rows != input_.height) {
    throw std::invalid_argument("Undistorter: frame is " + std::to_string(distorted.cols) + "x" +
                                std::to_string(distorted.rows) + ", calibration is " +
                                std::to_string(input_.width) + "x" + std::to_string(input_.height));
  }
  if (map_xy_.empty()) return distorted;
  cv::Mat out;
  cv::remap(distorted, out, map_xy_, map_frac_, cv::INTER_LINEAR, cv::BORDER_CONSTANT);
  return out;
}

}  // namespace mm
