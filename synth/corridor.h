#pragma once
// A synthetic L-shaped indoor corridor with exact geometry (issue 9): floor, walls, ceiling,
// doors, posters and furniture boxes, every surface an axis-aligned rectangle with its own
// region of one texture atlas. The textures are procedural and seeded (multi-scale value noise,
// random rectangles and ellipses, Hershey-font text, tile grids, posters), so SIFT and KLT find
// texture everywhere, floor and ceiling included. Each floor/wall panel and poster carries a
// marker at its centre (a magenta disc in a black ring): a known 3-D point of known colour for
// ground-truth checks.
//
// World frame: metres, z up, the floor at z = 0. Leg 1 runs along +y (x in [-w/2, w/2]) from
// the start wall at y = -2 to the outer wall of the corner; leg 2 turns right along +x
// (y in [corner_y - w, corner_y]) to its end wall (docs/synth.md draws it).
//
// Thread-safety: pure functions; reentrant.

#include <Eigen/Geometry>
#include <cstdint>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "recon/mesh.h"

namespace mm {

struct CorridorOptions {
  uint64_t seed = 1;            ///< Textures, doors, posters and boxes; same seed, same scene.
  double width_m = 2.0;         ///< Both legs, wall to wall.
  double height_m = 2.5;        ///< Floor to ceiling.
  double leg1_length_m = 11.0;  ///< Start wall (y = -2) to the outer wall of the corner.
  double leg2_length_m = 11.0;  ///< Outer wall of leg 1 (x = -w/2) to the end wall.
  double panel_m = 2.5;         ///< Floor, wall and ceiling are split into panels this large.
  int doors = 5;                ///< Doors, on the long walls.
  int posters = 12;             ///< Posters, on the long walls.
  int boxes = 8;                ///< Furniture boxes along the walls (clear of the walk).
  /// Atlas edge in texels: 4096 gives ~3 mm per texel here (a 640x480 pixel at 1.5 m is ~3 mm);
  /// GLES 3.0 guarantees only 2048, Mesa and the Raspberry Pi 4/5 GPUs take 4096 or more.
  int atlas_size = 4096;
  double marker_radius_m = 0.04;  ///< The magenta disc; its black ring reaches 1.6x this.
  [[nodiscard]] std::string Check() const;
};

enum class SurfaceKind { kFloor, kCeiling, kWall, kDoor, kPoster, kBox };

/// A rectangle of the scene: the corners are origin, origin + edge_u, origin + edge_u + edge_v,
/// origin + edge_v. The texture's columns run along edge_u, its rows along edge_v.
struct SceneQuad {
  Eigen::Vector3d origin = Eigen::Vector3d::Zero();
  Eigen::Vector3d edge_u = Eigen::Vector3d::UnitX();
  Eigen::Vector3d edge_v = Eigen::Vector3d::UnitY();
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();  ///< Unit, towards the side seen.
  SurfaceKind kind = SurfaceKind::kWall;
  cv::Rect atlas_rect;  ///< Its texels in the atlas (without the padding around them).
};

/// A marker: a magenta disc of `radius_m` at `centre` in a black ring, on the plane with
/// `normal` (facing the corridor).
struct SceneMarker {
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();
  double radius_m = 0.0;
  int quad = -1;  ///< The quad it is painted on.
};

/// The marker colour (BGR, pure magenta); the ring is black.
inline const cv::Vec3b kMarkerBgr{255, 0, 255};

struct CorridorScene {
  CorridorOptions options;
  std::vector<SceneQuad> quads;
  std::vector<SceneMarker> markers;
  cv::Mat atlas;              ///< CV_8UC3 BGR, atlas_size square.
  double texels_per_m = 0.0;  ///< Texture resolution on every surface.
  Mesh mesh;                  ///< Two triangles per quad, world coordinates, UVs into atlas.
  double build_s = 0.0;       ///< Time taken to build (textures dominate).
};

/// Builds the corridor. \throws std::invalid_argument when options.Check() fails.
CorridorScene BuildCorridor(const CorridorOptions& options);

/// The walk's centre line: leg 1 along x = 0 up to the corner, a quarter circle of radius w/2
/// into leg 2, then along y = corner_y - w/2. Shared with the camera paths.
struct CorridorLayout {
  double half_width = 1.0;
  double start_y = -2.0;  ///< The start wall.
  double outer_y = 9.0;   ///< Leg 1's far (outer) wall; leg 2 spans [outer_y - w, outer_y].
  double end_x = 10.0;    ///< Leg 2's end wall.
  double height = 2.5;
};
CorridorLayout LayoutOf(const CorridorOptions& options);

/// First surface hit by the ray origin + t * direction (t > 1e-9): t and the quad index, or
/// quad = -1. Exact (double precision), for ground-truth checks of the rendered depth.
struct RayHit {
  double t = 0.0;
  int quad = -1;
};
RayHit CastRay(const CorridorScene& scene, const Eigen::Vector3d& origin,
               const Eigen::Vector3d& direction);

}  // namespace mm
