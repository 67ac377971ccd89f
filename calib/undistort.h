#pragma once
// Whole-frame undistortion with precomputed fixed-point remap tables built from the Bouguet
// model (skew included; cv::initUndistortRectifyMap ignores KK(0,1), so the maps are built here
// and packed by cv::convertMaps into OpenCV's 16.5 fixed-point format).
//
// Thread-safety: immutable after construction; Apply() is reentrant.

#include <opencv2/core.hpp>
#include <vector>

#include "calib/camera_model.h"

namespace mm {

class Undistorter {
 public:
  /// Maps from `camera` (distorted) to `camera.Undistorted()` at the calibrated image size.
  explicit Undistorter(const BouguetCamera& camera);

  /// Undistorts a gray or colour frame of the calibrated size. Without distortion the frame is
  /// returned as is (no copy).
  [[nodiscard]] cv::Mat Apply(const cv::Mat& distorted) const;

  /// Undistorts a map whose values must not be blended (a depth image, labels): each output
  /// pixel takes the input pixel nearest to where it comes from (the tables rounded).
  [[nodiscard]] cv::Mat ApplyNearest(const cv::Mat& distorted) const;

  /// Point undistortion for feature coordinates: pixels of the distorted frame -> pixels of
  /// output_camera() (exact iterative inverse, not the tables).
  [[nodiscard]] std::vector<cv::Point2f> UndistortPoints(
      const std::vector<cv::Point2f>& distorted) const;

  /// The camera an undistorted frame is seen through.
  [[nodiscard]] const BouguetCamera& output_camera() const { return output_; }

 private:
  BouguetCamera input_;
  BouguetCamera output_;
  cv::Mat map_xy_;    // CV_16SC2 integer part.
  cv::Mat map_frac_;  // CV_16UC1 fractional table index.
};

}  // namespace mm
