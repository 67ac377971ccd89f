#include "calib/opencv_camera.h"

#include <cmath>

namespace mm {

OpenCvCamera ToOpenCv(const BouguetCamera& c) {
  OpenCvCamera o;
  o.K =
      cv::Matx33d(c.fc.x(), c.alpha_c * c.fc.x(), c.cc.x(), 0.0, c.fc.y(), c.cc.y(), 0.0, 0.0, 1.0);
  o.dist.assign(c.kc.begin(), c.kc.end());
  o.size = cv::Size(c.width, c.height);
  return o;
}

std::string FromOpenCv(const cv::Matx33d& K, const std::vector<double>& dist, cv::Size size,
                       BouguetCamera* camera) {
  if (K(1, 0) != 0.0 || K(2, 0) != 0.0 || K(2, 1) != 0.0 || K(2, 2) != 1.0) {
    return "K: expected [fx s cx; 0 fy cy; 0 0 1]";
  }
  const size_t n = dist.size();
  if (n != 0 && n != 4 && n != 5 && n != 8 && n != 12 && n != 14) {
    return "dist: expected 0, 4, 5, 8, 12 or 14 values, got " + std::to_string(n);
  }
  for (size_t i = 5; i < n; ++i) {
    if (dist[i] != 0.0) {
      return "dist: coefficient " + std::to_string(i) +
             " is non-zero (rational/thin-prism/tilt terms are not in the Bouguet model)";
    }
  }
  BouguetCamera c;
  c.fc = {K(0, 0), K(1, 1)};
  c.cc = {K(0, 2), K(1, 2)};
  c.alpha_c = K(0, 0) != 0.0 ? K(0, 1) / K(0, 0) : 0.0;
  for (size_t i = 0; i < 5 && i < n; ++i) c.kc[i] = dist[i];
  c.width = size.width;
  c.height = size.height;
  if (std::string problem = c.Check(); !problem.empty()) return problem;
  *camera = c;
  return {};
}

}  // namespace mm
