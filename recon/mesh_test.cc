#include "recon/mesh.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cstring>
#include <opencv2/imgcodecs.hpp>
#include <sstream>

#include "recon/test_scenes.h"

namespace mm {
namespace {

using test::GridK;
using test::MakeGrid;

TEST(DelaunayMesh, GridGivesTwoTrianglesPerCell) {
  std::vector<Eigen::Vector3d> points;
  std::vector<Eigen::Vector2d> pixels;
  MakeGrid(6, &points, &pixels);
  MeshSummary summary;
  const Mesh mesh = BuildDelaunayMesh(points, pixels, 100, 100, MeshOptions{}, &summary);
  EXPECT_EQ(mesh.vertices.size(), 36u);
  EXPECT_EQ(mesh.triangles.size(), 2u * 5 * 5);
  // Grid points on the hull may come out not exactly collinear after the projection's rounding
  // (on aarch64 fused multiply-adds give 3 zero-area slivers along the border); the grazing
  // filter drops exactly those.
  EXPECT_EQ(summary.delaunay_triangles - summary.dropped_grazing_angle, 50);
  for (const Eigen::Vector2f& uv : mesh.uvs) {
    EXPECT_GE(uv.x(), 0.0f);
    EXPECT_LE(uv.x(), 1.0f);
    EXPECT_GE(uv.y(), 0.0f);
    EXPECT_LE(uv.y(), 1.0f);
  }
  // Front-facing from camera A: the normal of each triangle points back towards the camera.
  for (const Eigen::Vector3i& t : mesh.triangles) {
    const Eigen::Vector3f a = mesh.vertices[static_cast<size_t>(t[0])];
    const Eigen::Vector3f n = (mesh.vertices[static_cast<size_t>(t[1])] - a)
                                  .cross(mesh.vertices[static_cast<size_t>(t[2])] - a);
    EXPECT_LT(n.dot(a), 0.0f);
  }
}

TEST(DelaunayMesh, DropsDepthDiscontinuitiesWhenAsked) {
  std::vector<Eigen::Vector3d> points;
  std::vector<Eigen::Vector2d> pixels;
  MakeGrid(6, &points, &pixels);
  for (size_t i = 0; i < points.size(); ++i) {
    if (pixels[i].x() > 50) points[i] *= 3.0;  // A step in depth.
  }
  MeshOptions options;
  options.max_depth_ratio = 1.5;
  MeshSummary summary;
  const Mesh mesh = BuildDelaunayMesh(points, pixels, 100, 100, options, &summary);
  EXPECT_GT(summary.dropped_depth_discontinuity, 0);
  EXPECT_EQ(static_cast<int>(mesh.triangles.size()) + summary.dropped_depth_discontinuity +
                summary.dropped_grazing_angle,
            summary.delaunay_triangles);
}

TEST(DelaunayMesh, IgnoresPointsOutsideTheImageAndBehindTheCamera) {
  std::vector<Eigen::Vector3d> points{{0, 0, 1}, {0.3, 0, 1}, {0, 0.3, 1}, {5, 5, 1}, {0, 0, -1}};
  MeshOptions options;
  options.voxel_size = -1;
  MeshSummary summary;
  const Mesh mesh = BuildDelaunayMesh(points, GridK(), 100, 100, options, &summary);
  EXPECT_EQ(summary.points_in_image, 3);
  EXPECT_EQ(mesh.vertices.size(), 3u);
  EXPECT_EQ(mesh.triangles.size(), 1u);
}

TEST(DelaunayMesh, FitsTheCameraMatrixFromPointsAndPixels) {
  std::vector<Eigen::Vector3d> points;
  std::vector<Eigen::Vector2d> pixels;
  MakeGrid(5, &points, &pixels);
  for (size_t i = 0; i < points.size(); ++i) points[i] *= 1.0 + 0.1 * static_cast<double>(i % 3);
  const Eigen::Matrix3d K = FitCameraMatrix(points, pixels);
  EXPECT_TRUE(K.isApprox(GridK(), 1e-9)) << K;
}

TEST(DelaunayMesh, VoxelGridKeepsCellsWithEnoughPointsAtCentreOrCentroid) {
  // Three points in cell (0,0,20) of size 0.1, one alone in cell (2,0,20).
  const std::vector<Eigen::Vector3d> points{
      {0.01, 0.02, 2.01}, {0.03, 0.04, 2.03}, {0.05, 0.06, 2.05}, {0.25, 0.05, 2.05}};
  MeshOptions options;
  options.voxel_size = 0.1;
  options.min_points_per_cell = 3;
  options.voxel_vertex = VoxelVertex::kCentroid;
  MeshSummary summary;
  Mesh mesh = BuildDelaunayMesh(points, GridK(), 100, 100, options, &summary);
  EXPECT_EQ(summary.occupied_cells, 2);
  EXPECT_EQ(summary.kept_cells, 1);
  ASSERT_EQ(mesh.vertices.size(), 1u);
  EXPECT_TRUE(mesh.vertices[0].isApprox(Eigen::Vector3f(0.03f, 0.04f, 2.03f), 1e-5f));
  // The UV is the vertex's projection through K.
  EXPECT_NEAR(mesh.uvs[0].x(), (100 * 0.03 / 2.03 + 50 + 0.5) / 100, 1e-5);
  options.voxel_vertex = VoxelVertex::kCellCentre;
  mesh = BuildDelaunayMesh(points, GridK(), 100, 100, options, &summary);
  ASSERT_EQ(mesh.vertices.size(), 1u);
  EXPECT_TRUE(mesh.vertices[0].isApprox(Eigen::Vector3f(0.05f, 0.05f, 2.05f), 1e-5f));
  options.min_points_per_cell = 1;
  mesh = BuildDelaunayMesh(points, GridK(), 100, 100, options, &summary);
  EXPECT_EQ(mesh.vertices.size(), 2u);
}

TEST(DelaunayMesh, AutomaticCellSizeFollowsThePointSpread) {
  std::vector<Eigen::Vector3d> points;
  std::vector<Eigen::Vector2d> pixels;
  MakeGrid(11, &points, &pixels);  // x and y span [-0.8, 0.8]: 10-90 % range 1.28.
  MeshOptions options;
  options.voxel_auto_fraction = 0.25;
  MeshSummary summary;
  BuildDelaunayMesh(points, GridK(), 100, 100, options, &summary);
  EXPECT_NEAR(summary.voxel_size, 0.25 * 1.28, 1e-9);
  EXPECT_LT(summary.kept_cells, 121);  // Coarse cells merge points.
  for (auto& p : points) p *= 2.0;
  MeshSummary doubled;
  BuildDelaunayMesh(points, GridK(), 100, 100, options, &doubled);
  EXPECT_NEAR(doubled.voxel_size, 2 * summary.voxel_size, 1e-9);
  EXPECT_EQ(doubled.kept_cells, summary.kept_cells);
}

TEST(DelaunayMesh, DropsTrianglesSeenAtGrazingAngles) {
  // A plane seen almost edge-on: z grows fast with x (the normal is ~80 deg off the rays).
  std::vector<Eigen::Vector3d> points;
  for (int i = 0; i < 6; ++i) {
    for (int j = 0; j < 6; ++j) {
      const double x = 0.1 * i - 0.25, y = 0.1 * j - 0.25;
      points.emplace_back(x, y, 2.0 + 0.6 * x / 0.1);
    }
  }
  MeshOptions options;
  options.voxel_size = -1;
  options.max_depth_ratio = 0;
  options.max_grazing_angle_deg = 0;
  MeshSummary kept;
  BuildDelaunayMesh(points, GridK(), 100, 100, options, &kept);
  EXPECT_EQ(kept.dropped_grazing_angle, 0);
  options.max_grazing_angle_deg = 60;
  MeshSummary dropped;
  const Mesh mesh = BuildDelaunayMesh(points, GridK(), 100, 100, options, &dropped);
  EXPECT_GT(dropped.dropped_grazing_angle, kept.triangles / 2);
  EXPECT_EQ(dropped.triangles + dropped.dropped_grazing_angle, dropped.delaunay_triangles);
  EXPECT_EQ(static_cast<int>(mesh.triangles.size()), dropped.triangles);
}

TEST(MeshOptions, CheckNamesTheBadField) {
  MeshOptions o;
  EXPECT_EQ(o.Check(), "");
  o.min_points_per_cell = 0;
  EXPECT_NE(o.Check().find("min_points_per_cell"), std::string::npos);
  o = MeshOptions{};
  o.max_grazing_angle_deg = 95;
  EXPECT_NE(o.Check().find("max_grazing_angle_deg"), std::string::npos);
  o = MeshOptions{};
  o.voxel_auto_fraction = 0;
  EXPECT_NE(o.Check().find("voxel_auto_fraction"), std::string::npos);
}

}  // namespace
}  // namespace mm
