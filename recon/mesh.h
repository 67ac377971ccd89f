#pragma once
// A textured triangle mesh from sparse two-view points, as in the method this project follows:
// a voxel grid over the 3-D points (one vertex per occupied cell that holds enough points),
// projection of the vertices into keyframe A, 2-D Delaunay triangulation of the projections
// (CGAL), triangles lifted back to 3-D and textured from keyframe A (UV = projection / image
// size). Beyond the method: triangles that span a depth discontinuity or are seen at a grazing
// angle from A are dropped, and counted.
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

/// Which point stands for a voxel cell.
enum class VoxelVertex {
  kCellCentre,  ///< The centre of the cell (the thesis).
  kCentroid,    ///< The mean of the cell's points.
};

struct MeshOptions {
  /// Voxel cell edge in scene units. 0 = derived from the point spread: voxel_auto_fraction
  /// times the largest 10-90 percentile range of the points along x, y, z. < 0 = no voxel
  /// grid: every point is a vertex.
  double voxel_size = 0.0;
  /// Cell edge as a fraction of the point spread when voxel_size == 0. From 1/24 to 1/200
  /// the TUM figures move < 0.5 % (few hundred points: most cells hold one point).
  double voxel_auto_fraction = 1.0 / 48.0;
  /// Keep a cell only when it holds at least this many points. The thesis keeps >= 3; with
  /// the few hundred points of a 640x480 pair that leaves 0-3 vertices (measured on TUM
  /// (0,2), (0,3)), so the default keeps every occupied cell.
  int min_points_per_cell = 1;
  /// The cell's vertex. Cell centre (the thesis) and centroid measured within noise on TUM
  /// (0,2) and (0,3) (median depth error 2.37/3.50 % vs 2.28/3.72 %; p90 34.0 vs 34.8 % summed):
  /// the thesis' centre is the default.
  VoxelVertex voxel_vertex = VoxelVertex::kCellCentre;
  /// Drop a triangle whose largest / smallest vertex depth exceeds this (a depth
  /// discontinuity); 0 keeps every triangle. The option that moves the mesh most (TUM (0,3):
  /// median depth error 5.0 % off, 3.5 % at 1.3, 3.1 % at 1.15 but coverage < 40 %).
  double max_depth_ratio = 1.3;
  /// Drop a triangle whose normal is more than this many degrees from the ray from camera A
  /// to its centroid (seen edge-on: usually spans an occlusion boundary); 0 = off.
  double max_grazing_angle_deg = 85.0;
  [[nodiscard]] std::string Check() const;
};

struct MeshSummary {
  int input_points = 0;
  int points_in_image = 0;        ///< In front of A and inside the image.
  double voxel_size = 0.0;        ///< The cell edge used (0 when the grid is off).
  int occupied_cells = 0;
  int kept_cells = 0;             ///< Cells with >= min_points_per_cell points.
  int vertices = 0;
  int delaunay_triangles = 0;
  int dropped_depth_discontinuity = 0;
  int dropped_grazing_angle = 0;  ///< Counted only when not already dropped for depth.
  int triangles = 0;
};

/// Builds the mesh. `pixels_in_a[i]` is where `points_in_cam_a[i]` was observed in the
/// (undistorted) texture image of size width x height. The camera matrix is fitted (least
/// squares) to the points and their pixels; prefer the overload with K when it is known.
Mesh BuildDelaunayMesh(std::span<const Eigen::Vector3d> points_in_cam_a,
                       std::span<const Eigen::Vector2d> pixels_in_a, int width, int height,
                       const MeshOptions& options, MeshSummary* summary = nullptr);

/// Same, with camera A's matrix K (upper triangular, skew allowed). Vertices are projected
/// through K; points projecting outside the image are ignored.
Mesh BuildDelaunayMesh(std::span<const Eigen::Vector3d> points_in_cam_a, const Eigen::Matrix3d& K,
                       int width, int height, const MeshOptions& options,
                       MeshSummary* summary = nullptr);

/// The least-squares K (fx, skew, cx, fy, cy) mapping points to pixels; identity when there
/// are fewer than 3 usable points.
Eigen::Matrix3d FitCameraMatrix(std::span<const Eigen::Vector3d> points_in_cam,
                                std::span<const Eigen::Vector2d> pixels);

/// Fills mesh->colors with the texture's colour at each vertex's UV.
void ColorVerticesFromTexture(const cv::Mat& texture_bgr, Mesh* mesh);

}  // namespace mm
