#pragma once
// Calib_Results.m of the Caltech Camera Calibration Toolbox for Matlab (J.-Y. Bouguet): reader and
// writer (docs/calibration.md).
//
// The file is a Matlab script of assignments `name = value;` where value is a number or a vector
// `[ a ; b ; ... ]`; `%` starts a comment. The reader accepts what the toolbox and its ports write:
// CRLF or LF, %.15f / %e / %g numbers, 3-digit exponents (1.0e+000), NaN extrinsics of inactive
// images, 4- or 5-element kc, intrinsics-only files and either header wording. Unknown variables
// are ignored. Pixel convention: the toolbox's cc is already 0-based (the centre of the top-left
// pixel is (0,0), verified against OpenCV corners in
// ../shared/data/calib_opencv_bouguet_stereo_example/PROVENANCE.md), so it is stored unchanged.
//
// Thread-safety: reentrant.

#include <Eigen/Core>
#include <array>
#include <optional>
#include <string>
#include <vector>

#include "calib/camera_model.h"

namespace mm {

/// Which intrinsics the toolbox estimated (absent in intrinsics-only files).
struct CalibEstimationFlags {
  std::array<int, 2> est_fc{1, 1};
  int est_aspect_ratio = 1;
  int center_optim = 1;
  int est_alpha = 0;
  std::array<int, 5> est_dist{1, 1, 1, 1, 0};
};

/// Pose of the board in one calibration image: X_cam = R(omc) X_board + Tc (board units).
struct CalibImagePose {
  Eigen::Vector3d omc = Eigen::Vector3d::Zero();  ///< Rodrigues vector.
  Eigen::Vector3d tc = Eigen::Vector3d::Zero();   ///< Translation.
  std::optional<Eigen::Vector3d> omc_error;       ///< 3-sigma, when written.
  std::optional<Eigen::Vector3d> tc_error;
  /// False for an inactive image (the toolbox writes NaN) or one missing from the file.
  bool active = false;
};

/// Everything a Calib_Results.m holds.
struct CalibResults {
  BouguetCamera camera;  ///< With width/height from nx/ny and error from *_error.
  int n_ima = 0;         ///< 0 when the file has no n_ima.
  std::optional<CalibEstimationFlags> flags;
  std::vector<CalibImagePose> images;  ///< n_ima entries (image k is images[k-1]).
};

/// Parses Calib_Results.m text; `source_name` is used in error messages. fc, cc, kc, nx and ny
/// are required; fc must be finite and positive.
/// \throws CalibrationError "source:line: field 'name': problem".
CalibResults ParseCalibResultsM(const std::string& text, const std::string& source_name);

/// Writes the toolbox's layout (same comments, order and names). Numbers are written in the
/// shortest form that reads back to the same double, so ParseCalibResultsM round-trips exactly.
std::string FormatCalibResultsM(const CalibResults& results);

/// True when `text` looks like a Calib_Results.m (a `%` comment or an `fc = [` assignment
/// before any TOML table header).
bool LooksLikeCalibResultsM(const std::string& text);

}  // namespace mm
