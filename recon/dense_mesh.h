#pragma once
// A mesh of keyframe A from its dense inverse depth (recon/dense.h): vertices where the depth
// changes, from a quadtree over A's image (a cell splits while the inverse depth inside it
// departs from the bilinear interpolation of its corners, exact for a plane, or while it holds
// both pixels with and without depth; the worst cell first, until a vertex budget), the
// 2-D Delaunay triangulation of the leaf corners (recon/mesh.h), lifted by their depths and
// textured from A. A triangle is dropped where the depth has none (holes where the confidence
// is low), where the depth inside it departs from the triangle (it bridges two surfaces), and
// where its depth range exceeds what a surface slanted at most `max_slant_deg` from A's view
// can show over its size (plus the depth's noise) (a depth discontinuity: no rubber sheets).
//
// Thread-safety: pure functions; reentrant.

#include <Eigen/Core>
#include <string>

#include "recon/dense.h"
#include "recon/mesh.h"

namespace mm {

struct DenseMeshOptions {
  int max_cell_px = 32;  ///< Quadtree root cells (pixels of A, a power of two).
  int min_cell_px = 4;   ///< Smallest cell.
  /// A cell splits while its inverse depth departs from the corners' interpolation by more
  /// than this (relative) plus `noise_planes` of the sweep's plane spacing.
  double max_cell_deviation = 0.01;
  /// The depth's own noise in plane spacings (DenseDepth::inverse_depth_step), added to the
  /// split and the triangle tolerances so that quantization does not read as shape.
  double noise_planes = 1.0;
  /// Upper bound on the vertices: at 640x480 the default keeps mesh.glb with its texture
  /// under 2 MB.
  int vertex_budget = 12000;
  /// A triangle is dropped when the depth at its centroid or an edge midpoint departs from
  /// the triangle's own by more than this (relative), or is missing.
  double max_triangle_deviation = 0.05;
  /// The largest slant of a surface against A's image plane that the mesh keeps: a triangle
  /// whose inverse depths differ by more than rho_min (edge / f) tan(slant) plus twice the
  /// noise spans a discontinuity.
  double max_slant_deg = 80.0;
  [[nodiscard]] std::string Check() const;
};

struct DenseMeshSummary {
  int leaf_cells = 0;
  int vertices = 0;
  int delaunay_triangles = 0;
  int dropped_no_depth = 0;       ///< Centroid or an edge midpoint without depth.
  int dropped_bridging = 0;       ///< The depth inside departs from the triangle.
  int dropped_discontinuity = 0;  ///< Depth ratio beyond the slant limit.
  int triangles = 0;
  bool budget_reached = false;
};

/// The mesh of A (vertices in camera A's frame, UVs into A's image of width x height, K the
/// full-resolution camera matrix).
Mesh BuildDenseMesh(const DenseDepth& depth, const Eigen::Matrix3d& K, int width, int height,
                    const DenseMeshOptions& options, DenseMeshSummary* summary = nullptr);

}  // namespace mm
