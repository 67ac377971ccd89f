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

namespace {

void CheckSize(const cv::Mat& distorted, const BouguetCamera& input) {
  if (distorted.cols != input.width || distorted.rows != input.height) {
    throw std::invalid_argument("Undistorter: frame is " + std::to_string(distorted.cols) + "x" +
                                std::to_string(distorted.rows) + ", calibration is " +
                                std::to_string(input.width) + "x" + std::to_string(input.height));
  }
}

}  // namespace

cv::Mat Undistorter::Apply(const cv::Mat& distorted) const {
  CheckSize(distorted, input_);
  if (map_xy_.empty()) return distorted;
  cv::Mat out;
  cv::remap(distorted, out, map_xy_, map_frac_, cv::INTER_LINEAR, cv::BORDER_CONSTANT);
  return out;
}

cv::Mat Undistorter::ApplyNearest(const cv::Mat& distorted) const {
  CheckSize(distorted, input_);
  if (map_xy_.empty()) return distorted;
  // The fractional index is fy * INTER_TAB_SIZE + fx in 1/INTER_TAB_SIZE pixels: round with it.
  cv::Mat rounded(map_xy_.size(), CV_16SC2);
  for (int y = 0; y < map_xy_.rows; ++y) {
    const auto* xy = map_xy_.ptr<cv::Vec2s>(y);
    const auto* frac = map_frac_.ptr<uint16_t>(y);
    auto* out = rounded.ptr<cv::Vec2s>(y);
    for (int x = 0; x < map_xy_.cols; ++x) {
      const int fx = frac[x] % cv::INTER_TAB_SIZE;
      const int fy = frac[x] / cv::INTER_TAB_SIZE;
      out[x] = cv::Vec2s(static_cast<int16_t>(xy[x][0] + (2 * fx >= cv::INTER_TAB_SIZE ? 1 : 0)),
                         static_cast<int16_t>(xy[x][1] + (2 * fy >= cv::INTER_TAB_SIZE ? 1 : 0)));
    }
  }
  cv::Mat out;
  cv::remap(distorted, out, rounded, cv::Mat(), cv::INTER_NEAREST, cv::BORDER_CONSTANT);
  return out;
}

}  // namespace mm
