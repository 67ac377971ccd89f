#include "calib/camera_model.h"

#include <Eigen/LU>
#include <cmath>

namespace mm {

Eigen::Matrix3d BouguetCamera::K() const {
  Eigen::Matrix3d k;
  k << fc.x(), alpha_c * fc.x(), cc.x(), 0.0, fc.y(), cc.y(), 0.0, 0.0, 1.0;
  return k;
}

bool BouguetCamera::HasDistortion() const {
  for (double k : kc) {
    if (k != 0.0) return true;
  }
  return false;
}

Eigen::Vector2d BouguetCamera::Distort(const Eigen::Vector2d& x_n) const {
  return Distort(x_n, nullptr);
}

Eigen::Vector2d BouguetCamera::Distort(const Eigen::Vector2d& x_n,
                                       Eigen::Matrix2d* jacobian) const {
  const double x = x_n.x();
  const double y = x_n.y();
  const double r2 = x * x + y * y;
  const double r4 = r2 * r2;
  const double r6 = r4 * r2;
  const double radial = 1.0 + kc[0] * r2 + kc[1] * r4 + kc[4] * r6;
  const double dx = 2.0 * kc[2] * x * y + kc[3] * (r2 + 2.0 * x * x);
  const double dy = kc[2] * (r2 + 2.0 * y * y) + 2.0 * kc[3] * x * y;
  if (jacobian != nullptr) {
    // d radial / d r2, then chain rule with d r2 / dx = 2x, d r2 / dy = 2y.
    const double dradial_dr2 = kc[0] + 2.0 * kc[1] * r2 + 3.0 * kc[4] * r4;
    const double drx = dradial_dr2 * 2.0 * x;
    const double dry = dradial_dr2 * 2.0 * y;
    (*jacobian)(0, 0) = radial + x * drx + 2.0 * kc[2] * y + kc[3] * 6.0 * x;
    (*jacobian)(0, 1) = x * dry + 2.0 * kc[2] * x + kc[3] * 2.0 * y;
    (*jacobian)(1, 0) = y * drx + kc[2] * 2.0 * x + 2.0 * kc[3] * y;
    (*jacobian)(1, 1) = radial + y * dry + kc[2] * 6.0 * y + 2.0 * kc[3] * x;
  }
  return {radial * x + dx, radial * y + dy};
}

Eigen::Vector2d BouguetCamera::Undistort(const Eigen::Vector2d& x_d) const {
  if (!HasDistortion()) return x_d;
  Eigen::Vector2d x_n = x_d;
  for (int it = 0; it < 20; ++it) {
    Eigen::Matrix2d jac;
    const Eigen::Vector2d residual = Distort(x_n, &jac) - x_d;
    const Eigen::Vector2d step = jac.partialPivLu().solve(residual);
    x_n -= step;
    if (step.squaredNorm() < 1e-28) break;
  }
  return x_n;
}

Eigen::Vector2d BouguetCamera::PixelFromDistorted(const Eigen::Vector2d& x_d) const {
  return {fc.x() * (x_d.x() + alpha_c * x_d.y()) + cc.x(), fc.y() * x_d.y() + cc.y()};
}

Eigen::Vector2d BouguetCamera::DistortedFromPixel(const Eigen::Vector2d& pixel) const {
  const double y = (pixel.y() - cc.y()) / fc.y();
  const double x = (pixel.x() - cc.x()) / fc.x() - alpha_c * y;
  return {x, y};
}

Eigen::Vector2d BouguetCamera::Project(const Eigen::Vector3d& point_in_cam) const {
  const Eigen::Vector2d x_n = point_in_cam.head<2>() / point_in_cam.z();
  return PixelFromDistorted(Distort(x_n));
}

Eigen::Vector2d BouguetCamera::Unproject(const Eigen::Vector2d& pixel) const {
  return Undistort(DistortedFromPixel(pixel));
}

BouguetCamera BouguetCamera::Undistorted() const {
  BouguetCamera out = *this;
  out.kc = {};
  out.error.reset();
  return out;
}

std::string BouguetCamera::Check() const {
  if (!std::isfinite(fc.x()) || !std::isfinite(fc.y()) || fc.x() <= 0 || fc.y() <= 0) {
    return "fc: focal lengths must be finite and positive";
  }
  if (!std::isfinite(cc.x()) || !std::isfinite(cc.y())) return "cc: must be finite";
  if (!std::isfinite(alpha_c)) return "alpha_c: must be finite";
  for (double k : kc) {
    if (!std::isfinite(k)) return "kc: coefficients must be finite";
  }
  if (width < 0 || height < 0) return "image_size: must be non-negative";
  return {};
}

}  // namespace mm
