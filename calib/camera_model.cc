#include "calib/camera_model.h"

#include <Eigen/LU>
#include <algorithm>
#include <cmath>
#include <numbers>
#include <sstream>
#include <vector>

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
    // Explicit 2x2 solve (Cramer's rule): cheap, and the Jacobian is near identity for lenses.
    const double det = jac(0, 0) * jac(1, 1) - jac(0, 1) * jac(1, 0);
    if (det == 0.0 || !std::isfinite(det)) break;
    const double sx = (jac(1, 1) * residual.x() - jac(0, 1) * residual.y()) / det;
    const double sy = (jac(0, 0) * residual.y() - jac(1, 0) * residual.x()) / det;
    x_n.x() -= sx;
    x_n.y() -= sy;
    const Eigen::Vector2d step(sx, sy);
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
  const IntrinsicsVector intrinsics = Intrinsics();
  Eigen::Vector2d pixel;
  ProjectBouguet(intrinsics.data(), point_in_cam.data(), pixel.data());
  return pixel;
}

Eigen::Vector2d BouguetCamera::Unproject(const Eigen::Vector2d& pixel) const {
  return Undistort(DistortedFromPixel(pixel));
}

BouguetCamera::IntrinsicsVector BouguetCamera::Intrinsics() const {
  IntrinsicsVector p;
  p << fc.x(), fc.y(), cc.x(), cc.y(), alpha_c, kc[0], kc[1], kc[2], kc[3], kc[4];
  return p;
}

void BouguetCamera::SetIntrinsics(const IntrinsicsVector& p) {
  fc = {p[0], p[1]};
  cc = {p[2], p[3]};
  alpha_c = p[4];
  for (int i = 0; i < 5; ++i) kc[static_cast<size_t>(i)] = p[5 + i];
}

Eigen::Vector2d BouguetCamera::Project(
    const Eigen::Vector3d& point_in_cam, Eigen::Matrix<double, 2, 3>* d_point,
    Eigen::Matrix<double, 2, kNumIntrinsics>* d_intrinsics) const {
  const double inv_z = 1.0 / point_in_cam.z();
  const Eigen::Vector2d x_n = point_in_cam.head<2>() * inv_z;
  Eigen::Matrix2d d_distort;
  const Eigen::Vector2d x_d = Distort(x_n, &d_distort);
  // d pixel / d x_d: the upper 2x2 of KK.
  Eigen::Matrix2d a;
  a << fc.x(), fc.x() * alpha_c, 0.0, fc.y();
  if (d_point != nullptr) {
    Eigen::Matrix<double, 2, 3> d_xn;
    d_xn << inv_z, 0.0, -x_n.x() * inv_z, 0.0, inv_z, -x_n.y() * inv_z;
    *d_point = a * d_distort * d_xn;
  }
  if (d_intrinsics != nullptr) {
    const double x = x_n.x(), y = x_n.y();
    const double r2 = x * x + y * y, r4 = r2 * r2, r6 = r4 * r2;
    Eigen::Matrix<double, 2, kNumIntrinsics>& j = *d_intrinsics;
    j.setZero();
    j(0, 0) = x_d.x() + alpha_c * x_d.y();  // fc1
    j(1, 1) = x_d.y();                      // fc2
    j(0, 2) = 1.0;                          // cc1
    j(1, 3) = 1.0;                          // cc2
    j(0, 4) = fc.x() * x_d.y();             // alpha_c
    // d x_d / d kc, mapped through KK.
    j.col(5) = a * (r2 * x_n);
    j.col(6) = a * (r4 * x_n);
    j.col(7) = a * Eigen::Vector2d(2.0 * x * y, r2 + 2.0 * y * y);
    j.col(8) = a * Eigen::Vector2d(r2 + 2.0 * x * x, 2.0 * x * y);
    j.col(9) = a * (r6 * x_n);
  }
  return PixelFromDistorted(x_d);
}

Eigen::Vector2d BouguetCamera::Unproject(const Eigen::Vector2d& pixel,
                                         Eigen::Matrix2d* d_pixel) const {
  const Eigen::Vector2d x_n = Unproject(pixel);
  if (d_pixel != nullptr) {
    Eigen::Matrix2d d_distort;
    (void)Distort(x_n, &d_distort);
    Eigen::Matrix2d a;
    a << fc.x(), fc.x() * alpha_c, 0.0, fc.y();
    *d_pixel = (a * d_distort).inverse();
  }
  return x_n;
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
  if (width > kMaxImageSide || height > kMaxImageSide) {
    return "image_size: must be at most " + std::to_string(kMaxImageSide) + " px per side";
  }
  return CheckInvertible();
}

std::string BouguetCamera::CheckInvertible() const {
  if (width <= 0 || height <= 0 || !HasDistortion()) return {};
  // An ellipse reaching 90 % of the way from the image centre to each edge: there the
  // distortion must be a local bijection (positive Jacobian determinant, i.e. not beyond a
  // fold of the radial polynomial) whose inverse projects back onto the pixel. The rim and the
  // corners are not required: calibration boards seldom reach them, and real fitted
  // polynomials fold there (among the test files, one folds at 98 % of the way to the right
  // edge, a Kinect v2 IR one at 95 % of the way to its corners).
  constexpr double kRequiredFraction = 0.9;
  const Eigen::Vector2d centre((width - 1) / 2.0, (height - 1) / 2.0);
  const Eigen::Vector2d half = kRequiredFraction * centre.cwiseMax(0.5);
  std::vector<Eigen::Vector2d> pixels;
  constexpr int kSteps = 16;
  for (int j = 0; j <= kSteps; ++j) {
    for (int i = 0; i <= kSteps; ++i) {
      const Eigen::Vector2d pixel((width - 1) * i / double(kSteps),
                                  (height - 1) * j / double(kSteps));
      if (((pixel - centre).array() / half.array()).matrix().squaredNorm() <= 1.0) {
        pixels.push_back(pixel);
      }
    }
  }
  constexpr int kRim = 64;
  for (int k = 0; k < kRim; ++k) {
    const double a = 2.0 * std::numbers::pi * k / kRim;
    pixels.push_back(centre + Eigen::Vector2d(half.x() * std::cos(a), half.y() * std::sin(a)));
  }
  constexpr double kMaxRoundTripPx = 0.05;
  for (const Eigen::Vector2d& pixel : pixels) {
    const Eigen::Vector2d x_d = DistortedFromPixel(pixel);
    const Eigen::Vector2d x_n = Undistort(x_d);
    Eigen::Matrix2d jacobian;
    const Eigen::Vector2d back = PixelFromDistorted(Distort(x_n, &jacobian));
    const double moved_px = (back - pixel).norm();
    const bool folded = !(jacobian.determinant() > 0.0);
    // The ray's distance from the axis over the pinhole's: a lens bends it, but by more than
    // kMaxRadialScale either way the focal lengths no longer describe the camera (kc = [1e6,
    // 1e6, 0, 0, 1e6] is monotonic and inverts, yet squeezes a 640x480 image into 10 px).
    const double scale = x_d.norm() > 1e-9 ? x_n.norm() / x_d.norm() : 1.0;
    const bool squeezed = !(scale <= kMaxRadialScale && scale >= 1.0 / kMaxRadialScale);
    if (folded || !(moved_px <= kMaxRoundTripPx) || squeezed) {
      std::ostringstream m;
      m << "kc: the distortion is not invertible over the " << width << "x" << height
        << " image: pixel (" << pixel.x() << ", " << pixel.y() << ") ";
      if (folded) {
        m << "lies beyond a fold of the distortion";
      } else if (!(moved_px <= kMaxRoundTripPx)) {
        m << "projects back " << moved_px << " px away (the undistortion does not converge to it)";
      } else {
        m << "is " << scale << " times as far from the principal point undistorted (at most "
          << kMaxRadialScale << " times as far or near)";
      }
      return m.str();
    }
  }
  return {};
}

}  // namespace mm
