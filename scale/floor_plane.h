#pragma once
// The floor among a reconstruction's points with its normal known: a RANSAC plane (Fischler &
// Bolles 1981) below the camera, its distance refitted to its inliers by least squares. The
// distance from the camera centre to it, in reconstruction units, against the camera's known
// height in metres, gives the scale.
//
// Thread-safety: pure.

#include <Eigen/Core>
#include <cstddef>
#include <cstdint>
#include <span>
#include <string>

namespace mm {

struct FloorPlaneOptions {
  /// Inlier band: a point is on the plane when its distance is below this fraction of the
  /// plane's distance from the camera (scale-free: the reconstruction's units are arbitrary).
  double inlier_distance_rel = 0.02;
  int min_inliers = 30;
  /// Of the planes with at least this fraction of the best supported one's points, the lowest
  /// is the floor (a table top can have more points in view than the floor below it).
  double lower_plane_support = 0.5;
  /// Hypotheses, one point each, among those below the camera.
  int iterations = 2000;
  uint32_t seed = 1;
  /// A plane closer to the camera than this share of the median depth of the points below it
  /// is not a floor (dense points at the camera centre would hold a plane through it).
  double min_distance_rel = 0.02;
};

struct FloorPlane {
  bool found = false;
  std::string why_not;  ///< When not found.
  /// n . X + d = 0 in camera A's frame, n unit and pointing up (towards the camera), d > 0:
  /// the camera centre's distance from the plane in reconstruction units.
  Eigen::Vector3d normal = Eigen::Vector3d::Zero();
  double distance = 0.0;
  int inliers = 0;
  double rms_residual = 0.0;      ///< Of the inliers, in reconstruction units.
  double normal_angle_deg = 0.0;  ///< Between the normal and the expected up direction.
};

/// The floor among `points_in_cam` (the camera's frame: x right, y down, z forward) with its
/// normal known to be `up_in_cam` (from the room's walls, scale/room_planes.h, or the image's
/// vertical vanishing point, scale/vertical_vanishing_point.h): one point fixes a hypothesis,
/// and the inliers refine only the distance. For a floor seen as a shallow strip, whose own
/// points fix its pitch poorly.
FloorPlane FitFloorPlaneAlong(std::span<const Eigen::Vector3d> points_in_cam,
                              const Eigen::Vector3d& up_in_cam,
                              const FloorPlaneOptions& options = {});

/// A horizontal plane below the camera: its distance from the camera and its points.
struct HorizontalPlaneCandidate {
  double distance = 0.0;
  size_t support = 0;
};

/// The floor among horizontal planes below the camera: of those with at least
/// `lower_plane_support` times the best supported one's points, the lowest (a table top can
/// have more points in view than the floor below it); candidates within `same_plane_rel` of
/// each other's distance are one plane, and the better supported one stands for it. Returns
/// its index, -1 when there is none.
int ChooseFloorPlane(std::span<const HorizontalPlaneCandidate> candidates,
                     double lower_plane_support, double same_plane_rel);

/// World up in the frame of a camera pitched down by `pitch_down_deg` about its x axis (no
/// roll): (0, -cos p, -sin p); a level camera's up is -y.
Eigen::Vector3d UpInCamera(double pitch_down_deg);

}  // namespace mm
