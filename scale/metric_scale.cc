#include "scale/metric_scale.h"

#include <cmath>
#include <cstdio>

namespace mm {
namespace {

std::string Fixed(double v, int digits = 3) {
  char buf[48];
  std::snprintf(buf, sizeof(buf), "%.*f", digits, v);
  return buf;
}

void AppendWhy(std::string* why, const std::string& more) {
  if (!why->empty()) *why += "; ";
  *why += more;
}

}  // namespace

const char* ScaleSourceName(ScaleSource source) {
  switch (source) {
    case ScaleSource::kNone:
      return "none";
    case ScaleSource::kOdometry:
      return "odometry";
    case ScaleSource::kFloor:
      return "floor";
    case ScaleSource::kAuto:
      return "auto";
  }
  return "?";
}

std::optional<ScaleSource> ParseScaleSource(const std::string& name) {
  for (ScaleSource s :
       {ScaleSource::kNone, ScaleSource::kOdometry, ScaleSource::kFloor, ScaleSource::kAuto}) {
    if (name == ScaleSourceName(s)) return s;
  }
  return std::nullopt;
}

std::string ScaleOptions::Check() const {
  if (!(camera_height_m >= 0 && camera_height_m < 100))
    return "camera_height_m: must be in [0, 100)";
  if (!(std::abs(camera_pitch_deg) <= 90)) return "camera_pitch_deg: must be in [-90, 90]";
  if (!(min_baseline_m >= 0 && min_baseline_m < 100)) return "min_baseline_m: must be in [0, 100)";
  if (!(max_disagreement_rel > 0 && max_disagreement_rel <= 1)) {
    return "max_disagreement_rel: must be in (0, 1]";
  }
  if (source == ScaleSource::kFloor && !(camera_height_m > 0)) {
    return "camera_height_m: source = \"floor\" needs the camera's height above the floor";
  }
  return {};
}

ScaleEstimate EstimateScale(const ScaleInputs& inputs, const ScaleOptions& options) {
  ScaleEstimate out;
  if (options.source == ScaleSource::kNone) return out;
  if (!(inputs.baseline_units > 0) || !std::isfinite(inputs.baseline_units)) {
    out.why_not = "the reconstruction has no baseline";
    return out;
  }
  const bool want_odometry =
      options.source == ScaleSource::kOdometry || options.source == ScaleSource::kAuto;
  const bool want_floor =
      options.camera_height_m > 0 &&
      (options.source == ScaleSource::kFloor || options.source == ScaleSource::kAuto ||
       options.source == ScaleSource::kOdometry);  // As the cross-check.

  double odometry_sigma = 0.0;
  if (want_odometry) {
    if (!inputs.odometry_a_m || !inputs.odometry_b_m) {
      AppendWhy(&out.why_not, "odometry: " + (inputs.odometry_why_not.empty()
                                                  ? std::string("none at the keyframes")
                                                  : inputs.odometry_why_not));
    } else {
      const double baseline_m = (*inputs.odometry_b_m - *inputs.odometry_a_m).norm();
      if (baseline_m < options.min_baseline_m) {
        AppendWhy(&out.why_not, "odometry: baseline " + Fixed(baseline_m) + " m < min_baseline_m " +
                                    Fixed(options.min_baseline_m) + " m");
      } else {
        out.odometry_metres_per_unit = baseline_m / inputs.baseline_units;
        // Two independent positions: sigma of their distance is sqrt(2) sigma.
        odometry_sigma = std::sqrt(2.0) * options.odometry_sigma_m / baseline_m;
      }
    }
  }
  double floor_sigma = 0.0;
  if (want_floor) {
    // The floor among the room's planes, its normal held at the up direction that the walls
    // and every horizontal plane agree on (scale/room_planes.h). With no wall in view, the
    // image's vertical lines fix the up direction when they show it (the floor strip alone
    // fixes its pitch poorly).
    const Eigen::Vector3d nominal_up = UpInCamera(options.camera_pitch_deg);
    out.room = FitRoomPlanes(inputs.points_in_a, nominal_up, options.room);
    out.floor = out.room.floor;
    if (!out.room.found) {
      out.floor.why_not = out.room.why_not;
    } else if (out.room.walls == 0 && !inputs.gray_a.empty()) {
      out.vertical =
          EstimateVerticalVanishingPoint(inputs.gray_a, inputs.K, nominal_up, options.vertical);
      if (out.vertical.found)
        out.floor = FitFloorPlaneAlong(inputs.points_in_a, out.vertical.up_in_cam, options.floor);
    }
    if (!out.floor.found) {
      if (options.source != ScaleSource::kOdometry)
        AppendWhy(&out.why_not, "floor: " + out.floor.why_not);
    } else {
      out.floor_metres_per_unit = options.camera_height_m / out.floor.distance;
      // The plane's offset is known to rms / sqrt(inliers); the height to its own sigma.
      const double fit = out.floor.rms_residual /
                         (out.floor.distance * std::sqrt(static_cast<double>(out.floor.inliers)));
      floor_sigma = std::hypot(fit, options.camera_height_sigma_rel);
    }
  }

  const bool have_odometry = out.odometry_metres_per_unit > 0;
  const bool have_floor = out.floor_metres_per_unit > 0;
  if (have_odometry && have_floor) {
    const double disagreement = std::abs(out.floor_metres_per_unit - out.odometry_metres_per_unit) /
                                out.odometry_metres_per_unit;
    if (disagreement > options.max_disagreement_rel) {
      AppendWhy(&out.why_not, "odometry (" + Fixed(out.odometry_metres_per_unit, 4) +
                                  " m/unit) and floor (" + Fixed(out.floor_metres_per_unit, 4) +
                                  " m/unit) disagree by " + Fixed(100 * disagreement, 1) +
                                  " % > max_disagreement_rel");
      return out;
    }
  }
  if (have_odometry && options.source != ScaleSource::kFloor) {
    out.source = ScaleSource::kOdometry;
    out.metres_per_unit = out.odometry_metres_per_unit;
    out.uncertainty_rel = odometry_sigma;
  } else if (have_floor && options.source != ScaleSource::kOdometry) {
    out.source = ScaleSource::kFloor;
    out.metres_per_unit = out.floor_metres_per_unit;
    out.uncertainty_rel = floor_sigma;
  }
  return out;
}

}  // namespace mm
