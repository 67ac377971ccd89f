#pragma once
// Camera paths through the synthetic corridor (synth/corridor.h), as smooth functions of time:
//   walk     down leg 1 at walking pace and round the corner into leg 2, looking ahead along the
//            path, with head motion (vertical bob at the step rate, lateral sway at half of it,
//            slow small head turns and a little roll);
//   rotate   pure rotation about a fixed camera centre (pan and tilt), no translation at all;
//   forward  pure translation along the optical axis, no rotation at all.
// The last two are the hard cases of two-view geometry (no baseline; epipole in the image).
// Poses are world_from_cam with the OpenCV camera axes (x right, y down, z forward).
//
// Thread-safety: pure functions; reentrant.

#include <Eigen/Geometry>
#include <optional>
#include <string>

#include "synth/corridor.h"

namespace mm {

enum class CameraPathKind { kWalk, kRotate, kForward };

/// "walk" | "rotate" | "forward", or nullopt.
std::optional<CameraPathKind> ParseCameraPathKind(const std::string& name);
const char* CameraPathName(CameraPathKind kind);

struct CameraPathOptions {
  CameraPathKind kind = CameraPathKind::kWalk;
  double eye_height_m = 1.6;  ///< Camera height above the floor.
  /// Walk / forward speed; slowed down when the sequence is longer than the corridor allows.
  double speed_mps = 1.0;
  double look_ahead_m = 1.0;     ///< walk: the camera looks at the path this far ahead.
  double step_hz = 1.8;          ///< walk: steps per second (the bob's frequency).
  double bob_m = 0.02;           ///< walk: vertical head bob amplitude.
  double sway_m = 0.015;         ///< walk: lateral sway amplitude (at step_hz / 2).
  double head_yaw_deg = 2.0;     ///< walk: slow head turns (0.23 Hz) amplitude.
  double head_pitch_deg = 1.5;   ///< walk: slow nods (0.17 Hz) amplitude.
  double roll_deg = 0.7;         ///< walk: roll with the sway.
  double pan_deg = 25.0;         ///< rotate: pan amplitude.
  double tilt_deg = 8.0;         ///< rotate: tilt amplitude.
  double rotate_period_s = 8.0;  ///< rotate: pan period (tilt at 1.6x that rate).
  [[nodiscard]] std::string Check() const;
};

/// world_from_cam at time t in [0, duration_s] of a sequence `duration_s` long.
Eigen::Isometry3d CameraPoseAt(const CorridorLayout& layout, const CameraPathOptions& options,
                               double t, double duration_s);

/// The path's length in metres over `duration_s` (0 for rotate).
double CameraPathLength(const CorridorLayout& layout, const CameraPathOptions& options,
                        double duration_s);

}  // namespace mm
