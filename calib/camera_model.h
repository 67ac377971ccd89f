#pragma once
// The Bouguet camera model (Caltech Camera Calibration Toolbox for Matlab, J.-Y. Bouguet):
//   x_n = [X/Z, Y/Z],  r^2 = |x_n|^2
//   x_d = (1 + kc1 r^2 + kc2 r^4 + kc5 r^6) x_n + dx
//   dx  = [2 kc3 x y + kc4 (r^2 + 2 x^2),  kc3 (r^2 + 2 y^2) + 2 kc4 x y]
//   u   = fc1 (x_d1 + alpha_c x_d2) + cc1,   v = fc2 x_d2 + cc2
// so KK = [fc1 alpha_c*fc1 cc1; 0 fc2 cc2; 0 0 1]. Pixel (0,0) is the centre of the top-left
// pixel (the toolbox's 1-based cc is stored 0-based, as OpenCV does).
//
// Thread-safety: a value type; const methods are reentrant.

#include <Eigen/Core>
#include <array>
#include <optional>
#include <string>
#include <vector>

namespace mm {

/// The Bouguet projection of a point in the camera frame for any scalar type (double, or
/// ceres::Jet in the calibration's residual): `intrinsics` in the order of
/// BouguetCamera::Intrinsics() [fc1 fc2 cc1 cc2 alpha_c kc1 kc2 kc3 kc4 kc5]; Z > 0 expected.
/// The one definition of the model: BouguetCamera::Project and CalibrateFromImages use it.
template <typename T>
void ProjectBouguet(const T* intrinsics, const T* point_in_cam, T* pixel) {
  const T x = point_in_cam[0] / point_in_cam[2];
  const T y = point_in_cam[1] / point_in_cam[2];
  const T* kc = intrinsics + 5;
  const T r2 = x * x + y * y;
  const T r4 = r2 * r2;
  const T r6 = r4 * r2;
  const T radial = T(1.0) + kc[0] * r2 + kc[1] * r4 + kc[4] * r6;
  const T dx = T(2.0) * kc[2] * x * y + kc[3] * (r2 + T(2.0) * x * x);
  const T dy = kc[2] * (r2 + T(2.0) * y * y) + T(2.0) * kc[3] * x * y;
  const T xd = radial * x + dx;
  const T yd = radial * y + dy;
  pixel[0] = intrinsics[0] * (xd + intrinsics[4] * yd) + intrinsics[2];
  pixel[1] = intrinsics[1] * yd + intrinsics[3];
}

/// The largest image side a calibration may give, pixels: above any camera the appliance
/// drives, and the undistortion maps of a 16384 x 16384 image still fit in memory (a
/// calibration of 10^6 px per side made OpenCV throw from the daemon's constructor).
inline constexpr int kMaxImageSide = 16384;

/// The toolbox's kc from the values a file lists: the first five, those it leaves out 0 (a
/// file may give fewer, e.g. kc = [k1 k2 p1 p2]).
inline std::array<double, 5> KcFromValues(const std::vector<double>& values) {
  std::array<double, 5> kc{};
  for (size_t i = 0; i < values.size() && i < kc.size(); ++i) kc[i] = values[i];
  return kc;
}

/// Intrinsics in the toolbox's parameterization, plus the image size they belong to.
struct BouguetCamera {
  Eigen::Vector2d fc{1.0, 1.0};  ///< Focal lengths, pixels.
  Eigen::Vector2d cc{0.0, 0.0};  ///< Principal point, pixels (0-based).
  double alpha_c = 0.0;          ///< Skew coefficient (angle between axes).
  std::array<double, 5> kc{};    ///< [k1 k2 p1 p2 k3] as in the toolbox.
  int width = 0;                 ///< Image width, pixels (0 = unknown).
  int height = 0;                ///< Image height, pixels (0 = unknown).

  /// Optional 3-sigma uncertainties as reported by the toolbox (fc_error ...).
  struct Uncertainty {
    Eigen::Vector2d fc{0, 0};
    Eigen::Vector2d cc{0, 0};
    double alpha_c = 0.0;
    std::array<double, 5> kc{};
  };
  std::optional<Uncertainty> error;

  /// KK = [fc1 alpha_c*fc1 cc1; 0 fc2 cc2; 0 0 1].
  [[nodiscard]] Eigen::Matrix3d K() const;
  /// True when any distortion coefficient is non-zero.
  [[nodiscard]] bool HasDistortion() const;

  /// Applies the distortion to a normalized point (x_n -> x_d).
  [[nodiscard]] Eigen::Vector2d Distort(const Eigen::Vector2d& x_n) const;
  /// Distortion with its 2x2 Jacobian d x_d / d x_n.
  [[nodiscard]] Eigen::Vector2d Distort(const Eigen::Vector2d& x_n,
                                        Eigen::Matrix2d* jacobian) const;
  /// Inverts the distortion by Gauss-Newton on Distort(x_n) = x_d (converges to 1e-12 in a few
  /// iterations for calibrated lenses; the toolbox's comp_distortion_oulu uses fixed-point).
  [[nodiscard]] Eigen::Vector2d Undistort(const Eigen::Vector2d& x_d) const;

  /// Order of the intrinsics in Jacobians and parameter vectors (the toolbox's order).
  static constexpr int kNumIntrinsics = 10;  // fc1 fc2 cc1 cc2 alpha_c kc1 kc2 kc3 kc4 kc5
  using IntrinsicsVector = Eigen::Matrix<double, kNumIntrinsics, 1>;
  [[nodiscard]] IntrinsicsVector Intrinsics() const;
  void SetIntrinsics(const IntrinsicsVector& p);

  /// Pixel of a point in the camera frame (Z > 0 expected).
  [[nodiscard]] Eigen::Vector2d Project(const Eigen::Vector3d& point_in_cam) const;
  /// Projection with analytic Jacobians w.r.t. the point (2x3) and the intrinsics (2x10, order
  /// of Intrinsics()); either may be null.
  Eigen::Vector2d Project(const Eigen::Vector3d& point_in_cam, Eigen::Matrix<double, 2, 3>* d_point,
                          Eigen::Matrix<double, 2, kNumIntrinsics>* d_intrinsics) const;
  /// Normalized, undistorted image coordinates [X/Z, Y/Z] of a (distorted) pixel.
  [[nodiscard]] Eigen::Vector2d Unproject(const Eigen::Vector2d& pixel) const;
  /// Unprojection with its Jacobian d x_n / d pixel (inverse of the projection's, by the
  /// implicit function theorem); `d_pixel` may be null.
  Eigen::Vector2d Unproject(const Eigen::Vector2d& pixel, Eigen::Matrix2d* d_pixel) const;

  /// Pixel <-> distorted normalized coordinates through KK (skew included).
  [[nodiscard]] Eigen::Vector2d PixelFromDistorted(const Eigen::Vector2d& x_d) const;
  [[nodiscard]] Eigen::Vector2d DistortedFromPixel(const Eigen::Vector2d& pixel) const;

  /// The same camera without distortion (what an undistorted frame is seen through).
  [[nodiscard]] BouguetCamera Undistorted() const;

  /// Empty when valid, otherwise a message naming the bad field. Includes CheckInvertible.
  [[nodiscard]] std::string Check() const;
  /// With an image size: empty when the distortion inverts over an ellipse reaching 90 % of
  /// the way to each image edge (a grid of pixels inside it and its rim unproject and project
  /// back within 0.05 px without crossing a fold, each at most kMaxRadialScale times as far
  /// from the principal point or as near undistorted), else a message naming kc and the pixel.
  [[nodiscard]] std::string CheckInvertible() const;
  /// How much farther from (or nearer to) the principal point a pixel's undistorted ray may
  /// lie than the pinhole puts it: wide barrel lenses fold before 1.5, pincushion stays near 1.
  static constexpr double kMaxRadialScale = 4.0;
};

}  // namespace mm
