#pragma once
// Calibration files. The appliance's stored format is TOML (docs/calibration.md):
//
//   [camera]
//   image_size = [640, 480]          # width, height in pixels
//   fc = [535.4, 539.2]              # focal lengths, pixels
//   cc = [320.1, 247.6]              # principal point, pixels, 0-based (as OpenCV)
//   alpha_c = 0.0                    # skew (optional, default 0)
//   kc = [0.0, 0.0, 0.0, 0.0, 0.0]   # k1 k2 p1 p2 k3 (4 or 5 values; k3 = 0 when 4)
//   [camera.error]                   # optional 3-sigma uncertainties, same keys
//
// Thread-safety: reentrant.

#include <filesystem>
#include <stdexcept>
#include <string>

#include "calib/camera_model.h"

namespace mm {

/// Thrown for a calibration file that cannot be used; the message names file, line and field.
class CalibrationError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// Loads a calibration from the stored TOML format or a toolbox Calib_Results.m (chosen by the
/// `.m` extension or the content, see LooksLikeCalibResultsM).
/// \throws CalibrationError naming the file, the line where known, and the field.
BouguetCamera LoadCalibration(const std::filesystem::path& path);

/// Parses the stored TOML format from text; `source_name` is used in error messages.
BouguetCamera ParseCalibrationToml(const std::string& text, const std::string& source_name);

/// Writes the stored TOML format (round-trips through ParseCalibrationToml exactly).
std::string FormatCalibrationToml(const BouguetCamera& camera);

}  // namespace mm
