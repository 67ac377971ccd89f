#include "synth/camera_path.h"

#include <algorithm>
#include <cmath>

namespace mm {
namespace {

constexpr double kDeg = M_PI / 180.0;

// The walk's centre line by arc length s (metres from the start at (0, 0)): leg 1 along x = 0,
// a quarter circle of radius w/2 whose centre is the corner's inner edge, then leg 2 along
// y = outer_y - w/2 to 1.5 m before its end wall. Beyond either end it continues straight.
struct CentreLine {
  explicit CentreLine(const CorridorLayout& l)
      : radius(l.half_width),
        turn_y(l.outer_y - l.half_width - radius),
        leg_a(turn_y),
        arc(M_PI / 2 * radius),
        leg_b(std::max(0.0, l.end_x - 1.5 - radius)) {}
  [[nodiscard]] double length() const { return leg_a + arc + leg_b; }
  [[nodiscard]] Eigen::Vector2d At(double s) const {
    if (s <= leg_a) return {0.0, s};
    if (s <= leg_a + arc) {
      const double theta = M_PI - (s - leg_a) / radius;
      return Eigen::Vector2d(radius, turn_y) +
             radius * Eigen::Vector2d(std::cos(theta), std::sin(theta));
    }
    return {radius + (s - leg_a - arc), turn_y + radius};
  }
  double radius, turn_y, leg_a, arc, leg_b;
};

// How far the forward path goes: from y = 0 to 1 m before leg 1 meets the corner.
double ForwardRange(const CorridorLayout& l) { return l.outer_y - 2 * l.half_width - 1.0; }

// World from camera for a camera at `position` whose heading has yaw `yaw` (about world z, 0 =
// looking along +y, positive = turning left), then pitch (positive = up) and roll about its own
// axes.
Eigen::Isometry3d Pose(const Eigen::Vector3d& position, double yaw, double pitch, double roll) {
  Eigen::Matrix3d level;  // Camera x right = +x, y down = -z, z forward = +y.
  level.col(0) = Eigen::Vector3d::UnitX();
  level.col(1) = -Eigen::Vector3d::UnitZ();
  level.col(2) = Eigen::Vector3d::UnitY();
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.linear() = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix() * level *
                  Eigen::AngleAxisd(pitch, Eigen::Vector3d::UnitX()).toRotationMatrix() *
                  Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  pose.translation() = position;
  return pose;
}

double Speed(const CorridorLayout& l, const CameraPathOptions& o, double duration_s) {
  const double range = o.kind == CameraPathKind::kWalk ? CentreLine(l).length() : ForwardRange(l);
  return duration_s > 0 ? std::min(o.speed_mps, range / duration_s) : o.speed_mps;
}

}  // namespace

std::optional<CameraPathKind> ParseCameraPathKind(const std::string& name) {
  if (name == "walk") return CameraPathKind::kWalk;
  if (name == "rotate") return CameraPathKind::kRotate;
  if (name == "forward") return CameraPathKind::kForward;
  return std::nullopt;
}

const char* CameraPathName(CameraPathKind kind) {
  switch (kind) {
    case CameraPathKind::kWalk:
      return "walk";
    case CameraPathKind::kRotate:
      return "rotate";
    case CameraPathKind::kForward:
      return "forward";
  }
  return "?";
}

std::string CameraPathOptions::Check() const {
  if (!(eye_height_m > 0.2)) return "eye_height_m: must be > 0.2";
  if (!(speed_mps > 0 && speed_mps <= 5)) return "speed_mps: must be in (0, 5]";
  if (!(look_ahead_m > 0)) return "look_ahead_m: must be > 0";
  if (!(step_hz > 0)) return "step_hz: must be > 0";
  if (!(rotate_period_s > 0)) return "rotate_period_s: must be > 0";
  if (!(std::abs(pan_deg) < 80 && std::abs(tilt_deg) < 60)) return "pan_deg/tilt_deg: too large";
  return {};
}

double CameraPathLength(const CorridorLayout& layout, const CameraPathOptions& options,
                        double duration_s) {
  if (options.kind == CameraPathKind::kRotate) return 0.0;
  return Speed(layout, options, duration_s) * duration_s;
}

Eigen::Isometry3d CameraPoseAt(const CorridorLayout& layout, const CameraPathOptions& o, double t,
                               double duration_s) {
  const double eye = std::min(o.eye_height_m, layout.height - 0.1);
  switch (o.kind) {
    case CameraPathKind::kRotate: {
      const double phase = 2 * M_PI * t / o.rotate_period_s;
      return Pose({0.0, 1.0, eye}, o.pan_deg * kDeg * std::sin(phase),
                  o.tilt_deg * kDeg * std::sin(1.6 * phase), 0.0);
    }
    case CameraPathKind::kForward:
      return Pose({0.0, Speed(layout, o, duration_s) * t, eye}, 0.0, 0.0, 0.0);
    case CameraPathKind::kWalk:
      break;
  }
  const CentreLine line(layout);
  const double s = Speed(layout, o, duration_s) * t;
  const Eigen::Vector2d here = line.At(s);
  const Eigen::Vector2d ahead = line.At(s + o.look_ahead_m) - here;
  const double heading = std::atan2(-ahead.x(), ahead.y());
  const Eigen::Vector2d right(std::cos(heading), std::sin(heading));
  const double step = 2 * M_PI * o.step_hz * t;
  const Eigen::Vector2d xy = here + right * (o.sway_m * std::sin(step / 2));
  const double z = eye + o.bob_m * std::sin(step);
  return Pose({xy.x(), xy.y(), z}, heading + o.head_yaw_deg * kDeg * std::sin(2 * M_PI * 0.23 * t),
              o.head_pitch_deg * kDeg * std::sin(2 * M_PI * 0.17 * t + 0.5),
              o.roll_deg * kDeg * std::sin(step / 2));
}

}  // namespace mm
