#pragma once
// The walk's map mesh: keyframe meshes in one segment's frame, merged where they overlap.
// Keyframes get a mesh part when the last part's keyframe sees at most `max_shared_points` of
// their map points (a new view of the scene, not the same one again). A part is the dense mesh
// of the keyframe (recon/dense.h plane sweep against its neighbour keyframe under the map's
// poses, recon/dense_mesh.h), or the sparse one of its map points (recon/mesh.h) where the
// dense depth fails. Merging (the mesh-merging alternative to volumetric fusion, in the sense
// of Turk & Levoy 1994's redundancy removal): a triangle of a later part is dropped when its
// centroid lies on the depth of one of the `overlap_parts` parts before it (within
// `overlap_depth_rel`), seen from that part's keyframe: a surface is kept once, from the
// keyframe that saw it first. Each part keeps its UVs into its own keyframe image.
//
// Thread-safety: pure functions; reentrant.

#include <Eigen/Core>
#include <functional>
#include <opencv2/core.hpp>
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
  int overlap_parts = 8;
  double overlap_depth_rel = 0.05;
  [[nodiscard]] std::string Check() const;
};

struct WalkMeshPart {
  int keyframe = 0;  ///< Its texture is this keyframe's image.
  Mesh mesh;         ///< Vertices in the segment's frame, UVs into the keyframe image, colours.
  bool dense = false;
  int dropped_overlap = 0;  ///< Triangles dropped as already in an earlier part.
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

/// The segment with the most registered keyframes (the lower index on a tie); -1: none.
int LargestSegment(const WalkMap& map);

/// The mesh of `segment` (K: the undistorted camera).
WalkMesh BuildWalkMesh(const WalkMap& map, int segment, const Eigen::Matrix3d& K,
                       const KeyframeImageFn& image_of, const WalkMeshOptions& options);

}  // namespace mm
