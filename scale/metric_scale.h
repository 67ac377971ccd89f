#pragma once
// Metric scale for a monocular pair: a two-view reconstruction is known up to scale (its
// baseline is the unit). Two things a robot knows fix it: how far it moved between the
// keyframes (odometry: metres per unit = |c_B - c_A| in metres / the baseline in units) and
// how high its camera sits above the floor (metres per unit = camera height / the distance
// from camera A to the floor plane, FitFloorPlane). When both are at hand they must agree;
// a disagreement is reported, never silently resolved.
//
// Thread-safety: pure.

#include <Eigen/Core>
#include <optional>
#include <span>
#include <string>

#include "scale/floor_plane.h"
#include "scale/room_planes.h"
#include "scale/vertical_vanishing_point.h"

namespace mm {

enum class ScaleSource { kNone, kOdometry, kFloor, kAuto };
/// "none", "odometry", "floor", "auto".
const char* ScaleSourceName(ScaleSource source);
/// The inverse of ScaleSourceName; nullopt for another word.
std::optional<ScaleSource> ParseScaleSource(const std::string& name);

struct ScaleOptions {
  /// auto: odometry when it is fresh and the baseline long enough, else the floor, else none.
  ScaleSource source = ScaleSource::kNone;
  double camera_height_m = 0.0;   ///< Above the floor; 0: the floor source is off.
  double camera_pitch_deg = 0.0;  ///< The mount's nominal pitch, down positive.
  double min_baseline_m = 0.05;   ///< A shorter odometry baseline is not used.
  /// Standard deviation of one odometry position (metres), for the uncertainty.
  double odometry_sigma_m = 0.01;
  /// Relative uncertainty of the camera height (the floor is not flat to the millimetre).
  double camera_height_sigma_rel = 0.01;
  /// Odometry and floor both at hand and further apart than this (relative): no scale.
  double max_disagreement_rel = 0.2;
  RoomPlanesOptions room;
  FloorPlaneOptions floor;
  VerticalVanishingOptions vertical;
  [[nodiscard]] std::string Check() const;
};

/// What one pair offers: the keyframes' odometry positions (when looked up: nullopt with
/// `odometry_why_not`), the reconstruction's baseline and points in camera A's frame.
struct ScaleInputs {
  std::optional<Eigen::Vector3d> odometry_a_m;
  std::optional<Eigen::Vector3d> odometry_b_m;
  std::string odometry_why_not;
  double baseline_units = 1.0;                   ///< |c_B - c_A| in the reconstruction.
  std::span<const Eigen::Vector3d> points_in_a;  ///< Units of the reconstruction.
  /// Keyframe A (undistorted, 8-bit grey) and its camera matrix, for the up direction from
  /// its vertical lines (floor source); empty: the floor's points alone fix its normal.
  cv::Mat gray_a;
  Eigen::Matrix3d K = Eigen::Matrix3d::Identity();
};

struct ScaleEstimate {
  ScaleSource source = ScaleSource::kNone;  ///< Used (kNone: unscaled).
  double metres_per_unit = 1.0;             ///< 1 when unscaled.
  double uncertainty_rel = 0.0;             ///< One sigma, relative.
  std::string why_not;                      ///< Why unscaled, or why a source was passed over.
  /// Each source's own figure, 0 when it gave none (for the report and the cross-check).
  double odometry_metres_per_unit = 0.0;
  double floor_metres_per_unit = 0.0;
  FloorPlane floor;
  /// The room's planes (floor source): the floor and the up direction its walls fix.
  RoomPlanes room;
  /// The up direction from A's vertical lines, looked for when the room shows no wall (then,
  /// when found, the floor's normal).
  VerticalVanishingPoint vertical;
  [[nodiscard]] bool scaled() const { return source != ScaleSource::kNone; }
};

ScaleEstimate EstimateScale(const ScaleInputs& inputs, const ScaleOptions& options);

}  // namespace mm
