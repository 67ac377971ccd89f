#pragma once
// A textured triangle mesh from sparse two-view points: project the points into keyframe A,
// 2-D Delaunay triangulation of the projections (CGAL), lift the triangles back to 3-D, and
// texture them from keyframe A (UV = projection / image size), as in the method this project
// follows.
//
// Thread-safety: pure functions; reentrant.

#include <Eigen/Core>
#include <opencv2/core.hpp>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

namespace mm {

struct Mesh {
  std::vector<Eigen::Vector3f> vertices;              ///< In camera A's frame.
  std::vector<Eigen::Vector2f> uvs;                   ///< Texture coordinates in [0,1]^2, v up.
  std::vector<Eigen::Matrix<uint8_t, 3, 1>> colors;   ///< RGB sampled from the texture.
  std::vector<Eigen::Vector3i> triangles;             ///< Counter-clockwise seen from camera A.
};

struct MeshOptions {
  /// Drop a triangle whose largest / smallest vertex depth exceeds this (a depth
  /// discontinuity); 0 keeps every triangle.
  double max_depth_ratio = 0.0;
  [[nodiscard]] std::string Check() const;
};

struct MeshSummary {
  int input_points = 0;
  int delaunay_triangles = 0;
  int dropped_depth_discontinuity = 0;
};

/// Builds the mesh. `pixels_in_a[i]` is where `points_in_cam_a[i]` projects in the (undistorted)
/// texture image of size width x height; points outside the image are ignored.
Mesh BuildDelaunayMesh(std::span<const Eigen::Vector3d> points_in_cam_a,
                       std::span<const Eigen::Vector2d> pixels_in_a, int width, int height,
                       const MeshOptions& options, MeshSummary* summary = nullptr);

/// Fills mesh->colors with the texture's colour at each vertex's UV.
void ColorVerticesFromTexture(const cv::Mat& texture_bgr, Mesh* mesh);

}  // namespace mm
