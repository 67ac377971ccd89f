#include "recon/mesh.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <sstream>

#include "recon/mesh_io.h"

namespace mm {
namespace {

// An n x n grid of points on the plane z = 2 seen by a camera with f = 100, c = (50, 50).
void MakeGrid(int n, std::vector<Eigen::Vector3d>* points, std::vector<Eigen::Vector2d>* pixels) {
  for (int i = 0; i < n; ++i) {
    for (int j = 0; j < n; ++j) {
      const Eigen::Vector2d px(10.0 + 80.0 * i / (n - 1), 10.0 + 80.0 * j / (n - 1));
      pixels->push_back(px);
      points->push_back(Eigen::Vector3d((px.x() - 50) / 100 * 2, (px.y() - 50) / 100 * 2, 2.0));
    }
  }
}

TEST(DelaunayMesh, GridGivesTwoTrianglesPerCell) {
  std::vector<Eigen::Vector3d> points;
  std::vector<Eigen::Vector2d> pixels;
  MakeGrid(6, &points, &pixels);
  MeshSummary summary;
  const Mesh mesh = BuildDelaunayMesh(points, pixels, 100, 100, MeshOptions{}, &summary);
  EXPECT_EQ(mesh.vertices.size(), 36u);
  EXPECT_EQ(mesh.triangles.size(), 2u * 5 * 5);
  EXPECT_EQ(summary.delaunay_triangles, 50);
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
  EXPECT_EQ(static_cast<int>(mesh.triangles.size()) + summary.dropped_depth_discontinuity,
            summary.delaunay_triangles);
}

TEST(DelaunayMesh, IgnoresPointsOutsideTheImage) {
  std::vector<Eigen::Vector3d> points{{0, 0, 1}, {1, 0, 1}, {0, 1, 1}, {5, 5, 1}};
  std::vector<Eigen::Vector2d> pixels{{1, 1}, {50, 1}, {1, 50}, {500, 500}};
  const Mesh mesh = BuildDelaunayMesh(points, pixels, 100, 100, MeshOptions{});
  EXPECT_EQ(mesh.vertices.size(), 3u);
  EXPECT_EQ(mesh.triangles.size(), 1u);
}

TEST(MeshIo, PlyHeaderAndSizeMatchContent) {
  std::vector<Eigen::Vector3d> points;
  std::vector<Eigen::Vector2d> pixels;
  MakeGrid(4, &points, &pixels);
  Mesh mesh = BuildDelaunayMesh(points, pixels, 100, 100, MeshOptions{});
  ColorVerticesFromTexture(cv::Mat(100, 100, CV_8UC3, cv::Scalar(10, 20, 30)), &mesh);
  ASSERT_EQ(mesh.colors.size(), mesh.vertices.size());
  EXPECT_EQ(mesh.colors[0][0], 30);  // RGB from BGR.
  const std::string ply = EncodePly(mesh, "test");
  const auto end = ply.find("end_header\n");
  ASSERT_NE(end, std::string::npos);
  EXPECT_NE(ply.find("element vertex 16\n"), std::string::npos);
  EXPECT_NE(ply.find("element face " + std::to_string(mesh.triangles.size()) + "\n"),
            std::string::npos);
  const size_t body = ply.size() - (end + 11);
  EXPECT_EQ(body, 16u * (12 + 3 + 8) + mesh.triangles.size() * 13);
}

TEST(MeshIo, ObjReferencesMaterialAndTexCoords) {
  std::vector<Eigen::Vector3d> points;
  std::vector<Eigen::Vector2d> pixels;
  MakeGrid(3, &points, &pixels);
  const Mesh mesh = BuildDelaunayMesh(points, pixels, 100, 100, MeshOptions{});
  const std::string obj = EncodeObj(mesh, "mesh.mtl");
  std::istringstream in(obj);
  std::string line;
  int v = 0, vt = 0, f = 0;
  while (std::getline(in, line)) {
    v += line.rfind("v ", 0) == 0;
    vt += line.rfind("vt ", 0) == 0;
    f += line.rfind("f ", 0) == 0;
  }
  EXPECT_EQ(v, 9);
  EXPECT_EQ(vt, 9);
  EXPECT_EQ(f, static_cast<int>(mesh.triangles.size()));
  EXPECT_NE(obj.find("mtllib mesh.mtl"), std::string::npos);
  EXPECT_NE(EncodeMtl("texture.jpg").find("map_Kd texture.jpg"), std::string::npos);
}

}  // namespace
}  // namespace mm
