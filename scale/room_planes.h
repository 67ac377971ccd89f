#pragma once
// The up direction and the floor from a room's planes: horizontal planes (floor, ceiling, table
// tops) share one normal, up, and every wall contains it (the Atlanta world of Schindler &
// Dellaert, CVPR 2004: walls need not meet at right angles). The planes are found one after
// another by RANSAC (Fischler & Bolles 1981) among the reconstruction's points, each taken as
// horizontal or as a wall by its angle to the mount's nominal up, and then fitted jointly: up
// (two angles), each horizontal plane's offset, each wall's azimuth about up and its offset, by
// Gauss-Newton on the points' distances to their planes, each over the point's depth (dense
// depth errs by a share of the depth).
//
// Why: a floor seen as a strip at a grazing angle fixes its own roll but hardly its pitch
// (docs/scale.md); a wall ahead (a corridor's end) fixes the pitch and a side wall the roll,
// while the floor's many points still fix the distance.
//
// Thread-safety: pure.

#include <Eigen/Core>
#include <cstdint>
#include <span>
#include <string>

#include "scale/floor_plane.h"

namespace mm {

struct RoomPlanesOptions {
  /// A plane is horizontal when its normal is within this of the nominal up, a wall when its
  /// normal is within this of perpendicular to it (degrees): the mount's pitch and the
  /// robot's sway are known to this much.
  double max_tilt_deg = 15.0;
  /// A point is on a plane when its distance is below this share of its depth.
  double inlier_distance_rel = 0.015;
  /// A plane needs this many points, and at least this share of all of them.
  int min_inliers = 30;
  double min_support_share = 0.02;
  int max_planes = 8;
  int iterations = 400;  ///< RANSAC samples per plane.
  /// Joint fits, each followed by a new choice of every plane's points.
  int rounds = 3;
  uint32_t seed = 1;
  /// The floor: of the horizontal planes below the camera with at least this share of the best
  /// supported one's points, the lowest (a table top can show more points than the floor).
  double lower_plane_support = 0.5;
  /// A plane closer to the camera than this share of the median depth of the points below it
  /// is no floor.
  double min_distance_rel = 0.02;
};

struct RoomPlanes {
  bool found = false;  ///< A floor was found.
  std::string why_not;
  /// World up in the camera's frame (x right, y down, z forward), unit; the floor's normal.
  Eigen::Vector3d up_in_cam = Eigen::Vector3d::Zero();
  /// n . X + d = 0 with n = up_in_cam; distance d in the reconstruction's units.
  FloorPlane floor;
  int horizontal_planes = 0;
  int walls = 0;
  /// Root mean square of the points' distances to their planes over their depths.
  double rms_residual_rel = 0.0;
};

/// `points_in_cam`: reconstructed points in the camera's frame (dense depth's, when at hand);
/// `nominal_up_in_cam`: the mount's nominal up (e.g. UpInCamera(pitch)).
RoomPlanes FitRoomPlanes(std::span<const Eigen::Vector3d> points_in_cam,
                         const Eigen::Vector3d& nominal_up_in_cam,
                         const RoomPlanesOptions& options = {});

}  // namespace mm
