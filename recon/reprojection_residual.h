#pragma once
// Pixel reprojection residuals, templated for automatic differentiation (the Ceres files'
// AutoDiffCostFunction evaluates them; this header needs only Eigen): the pinhole projection
// through K (skew included) minus the observed pixel.
//
// Thread-safety: immutable values.

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace mm {

/// r = proj(K x) - pixel, for x in the camera's frame.
template <typename T>
void PixelResidual(const Eigen::Matrix3d& k, const Eigen::Vector2d& pixel, const T* x, T* r) {
  const T u = x[0] / x[2];
  const T v = x[1] / x[2];
  r[0] = T(k(0, 0)) * u + T(k(0, 1)) * v + T(k(0, 2)) - T(pixel.x());
  r[1] = T(k(1, 1)) * v + T(k(1, 2)) - T(pixel.y());
}

/// A point given in the camera's own frame (the reference camera of a pair).
struct PointReprojection {
  PointReprojection(const Eigen::Matrix3d& k, const Eigen::Vector2d& pixel)
      : k_(k), pixel_(pixel) {}
  template <typename T>
  bool operator()(const T* p, T* r) const {
    PixelResidual(k_, pixel_, p, r);
    return true;
  }
  Eigen::Matrix3d k_;
  Eigen::Vector2d pixel_;
};

/// A point p seen by a camera cam_from_point_frame = (q, t): x = R(q) p + t, q as Eigen's
/// quaternion coefficients (x, y, z, w).
struct PoseReprojection {
  PoseReprojection(const Eigen::Matrix3d& k, const Eigen::Vector2d& pixel) : k_(k), pixel_(pixel) {}
  template <typename T>
  bool operator()(const T* q, const T* t, const T* p, T* r) const {
    const Eigen::Map<const Eigen::Quaternion<T>> rotation(q);
    const Eigen::Matrix<T, 3, 1> x = rotation * Eigen::Map<const Eigen::Matrix<T, 3, 1>>(p) +
                                     Eigen::Map<const Eigen::Matrix<T, 3, 1>>(t);
    PixelResidual(k_, pixel_, x.data(), r);
    return true;
  }
  Eigen::Matrix3d k_;
  Eigen::Vector2d pixel_;
};

}  // namespace mm
