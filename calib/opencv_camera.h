#pragma once
// Conversion between the Bouguet parameterization and OpenCV's camera matrix + distortion
// vector. Both use 0-based pixel centres and the same radial-tangential model, so
// K = KK = [fc1 alpha_c*fc1 cc1; 0 fc2 cc2; 0 0 1] and dist = [k1 k2 p1 p2 k3] = kc.
// Note: OpenCV's own projectPoints / undistort / initUndistortRectifyMap ignore K(0,1); a skewed
// camera must go through BouguetCamera::Project and mm::Undistorter instead.
//
// Thread-safety: reentrant.

#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "calib/camera_model.h"

namespace mm {

struct OpenCvCamera {
  cv::Matx33d K = cv::Matx33d::eye();
  std::vector<double> dist;  ///< k1 k2 p1 p2 k3.
  cv::Size size;
};

/// K (with skew in K(0,1)) and the 5-element distortion vector.
OpenCvCamera ToOpenCv(const BouguetCamera& camera);

/// Converts an OpenCV K + dist (0, 4, 5, 8, 12 or 14 values; the rational, thin-prism and tilt
/// terms must be zero since the Bouguet model has none). Returns "" or "field: problem".
[[nodiscard]] std::string FromOpenCv(const cv::Matx33d& K, const std::vector<double>& dist,
                                     cv::Size size, BouguetCamera* camera);

}  // namespace mm
