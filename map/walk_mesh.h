#pragma once
// The walk's map mesh: keyframe meshes in one segment's frame, merged where they overlap.
// Keyframes get a mesh part when the last part's keyframe sees at most `max_shared_points` of
// their map points (a new view of the scene, not the same one again). A part is the dense mesh
// of the keyframe (recon/dense.h plane sweep against its neighbour keyframe under the map's
// poses, recon/dense_mesh.h), or the sparse one of its map points (recon/mesh.h) where the
// dense depth fails.
//
// Visibility first (free-space carving, the visibility test of Merrell et al. 2007's depth-map
// fusion and the emptiness Curless & Levoy 1996 carve from their volume): a part's triangle is
// dropped when another part's keyframe sees through it, i.e. has, at a pixel the triangle
// covers, its own depth clearly behind it (beyond `free_space_depth_rel` and
// `free_space_noise_planes` of that depth's plane spacing; its nearest depth in a 3x3 window,
// so that depth edges do not count). This removes what mesh merging alone keeps: surfaces a
// keyframe saw at a slant or triangles bridging into a far end, which stand in front of the
// true surface in the views of other keyframes.
// Then merging (the mesh-merging alternative to volumetric fusion, in the sense of Turk &
// Levoy 1994's redundancy removal): a part's triangle is dropped when its centroid lies on
// the depth of what another part within `overlap_parts` kept (within `overlap_depth_rel`),
// seen from that part's keyframe, and that keyframe measured it more precisely (a smaller
// depth uncertainty z^2 times its sweep's inverse-depth plane spacing; the earlier part on a
// tie): a surface is kept once, from the keyframe that saw it best, as Curless & Levoy weigh
// their fusion. A corridor's far end, coarse from the first keyframe, is kept from the
// keyframes that walked up to it. Each part keeps its UVs into its own keyframe image.
//
// Thread-safety: pure functions; reentrant.

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <functional>
#include <opencv2/core.hpp>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "map/walk_map.h"
#include "recon/dense.h"
#include "recon/dense_mesh.h"
#include "recon/mesh.h"

namespace mm {

struct WalkMeshOptions {
  bool dense = true;  ///< False: every part is the sparse mesh of the keyframe's map points.
  DenseOptions depth;
  DenseMeshOptions dense_mesh;
  MeshOptions sparse;
  /// A keyframe gets a part when the last part's keyframe observes at most this share of the
  /// keyframe's map points.
  double max_shared_points = 0.5;
  int max_parts = 64;  ///< More candidates: every n-th is taken, evenly along the walk.
  /// A part's stereo partner: of the keyframes up to this many before and after it in the
  /// segment, the one that sees its map points under the widest median triangulation angle up
  /// to `max_stereo_angle_deg` (depth precision grows with the angle; past it the views differ
  /// too much for the window match), with at least `min_stereo_overlap` of the points in its
  /// image; none: the keyframe before it.
  int stereo_neighbours = 3;
  double max_stereo_angle_deg = 10.0;
  double min_stereo_overlap = 0.6;
  /// The next widest of them join the sweep as further views (recon/dense.h: their costs
  /// combined with the partner's, a view that does not see a point counts less).
  int stereo_extra_views = 1;
  int overlap_parts = 8;  ///< Parts before and after a part that can hold its surfaces.
  double overlap_depth_rel = 0.05;
  /// Free-space carving: a triangle is dropped when at least this many other parts'
  /// keyframes see through it (0: off). One suffices: the test is conservative (the view's
  /// nearest depth around the pixel, beyond the margins below).
  int free_space_min_views = 1;
  /// Seeing through: the keyframe's inverse depth at the pixel is below the triangle's by more
  /// than this share of it (the tolerance `overlap_depth_rel` gives "on the surface")...
  double free_space_depth_rel = 0.05;
  /// ...plus this many of the keyframe's sweep plane spacings (DenseDepth::inverse_depth_step,
  /// its depth resolution): twice the noise, as recon/dense_mesh.h's discontinuity test.
  double free_space_noise_planes = 2.0;
  [[nodiscard]] std::string Check() const;
};

struct WalkMeshPart {
  int keyframe = 0;  ///< Its texture is this keyframe's image.
  Mesh mesh;         ///< Vertices in the segment's frame, UVs into the keyframe image, colours.
  bool dense = false;
  int dropped_overlap = 0;     ///< Triangles another part holds more precisely.
  int dropped_free_space = 0;  ///< Triangles other keyframes see through.
};

struct WalkMeshSummary {
  int segment = -1;
  int segment_keyframes = 0;  ///< Registered keyframes of the segment.
  int parts = 0;
  int dense_parts = 0;
  int sparse_parts = 0;  ///< Dense failed (or off): the map points' mesh.
  int vertices = 0;
  int triangles = 0;
  int dropped_overlap = 0;
  int dropped_free_space = 0;
  double seconds = 0.0;
};

struct WalkMesh {
  std::vector<WalkMeshPart> parts;
  WalkMeshSummary summary;
  /// All parts in one mesh (vertex colours, no UVs): for rendering and evaluation.
  [[nodiscard]] Mesh Merged() const;
};

/// The undistorted BGR8 image of keyframe `index` (the walk keeps them encoded).
using KeyframeImageFn = std::function<cv::Mat(int index)>;

/// A keyframe's dense depth under the map's pose (none where its dense depth failed).
struct DepthView {
  Eigen::Isometry3d cam_from_segment = Eigen::Isometry3d::Identity();
  std::optional<DenseDepth> depth;
};

/// Free-space carving: per triangle of each mesh (segment frame; `meshes[i]` is the part of
/// `views[i]`), how many of the other views see through it, i.e. have their own depth clearly
/// behind it at a pixel it covers (WalkMeshOptions::free_space_*).
std::vector<std::vector<int>> FreeSpaceViolations(std::span<const Mesh* const> meshes,
                                                  std::span<const DepthView> views,
                                                  const WalkMeshOptions& options);

/// The segment with the most registered keyframes (the lower index on a tie); -1: none.
int LargestSegment(const WalkMap& map);

/// The mesh of `segment` (K: the undistorted camera).
WalkMesh BuildWalkMesh(const WalkMap& map, int segment, const Eigen::Matrix3d& K,
                       const KeyframeImageFn& image_of, const WalkMeshOptions& options);

}  // namespace mm
