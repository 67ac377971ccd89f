#include "map/walk_mesh.h"

#include <gtest/gtest.h>

#include <vector>

namespace mm {
namespace {

constexpr int kCols = 64, kRows = 48;

// A keyframe at (x, 0, 0) looking along +z whose depth map is `depth_left` left of column
// `edge` and `depth_right` from it on (0: no depth).
DepthView ViewAt(double x, double depth_left, double depth_right, int edge) {
  DepthView view;
  view.cam_from_segment = Eigen::Isometry3d::Identity();
  view.cam_from_segment.translation() = Eigen::Vector3d(-x, 0, 0);
  DenseDepth d;
  d.success = true;
  d.K << 50, 0, (kCols - 1) / 2.0, 0, 50, (kRows - 1) / 2.0, 0, 0, 1;
  d.inverse_depth = cv::Mat(kRows, kCols, CV_32FC1, cv::Scalar(0));
  for (int y = 0; y < kRows; ++y) {
    for (int u = 0; u < kCols; ++u) {
      const double z = u < edge ? depth_left : depth_right;
      d.inverse_depth.at<float>(y, u) = z > 0 ? static_cast<float>(1.0 / z) : 0.0f;
    }
  }
  d.inverse_depth_step = 0.002;  // Well below the 5 % margin at these depths.
  view.depth = std::move(d);
  return view;
}

// A small triangle facing the cameras, centred at (x, y, z), `size` across.
void AddTriangle(Mesh* mesh, double x, double y, double z, double size = 0.2) {
  const int base = static_cast<int>(mesh->vertices.size());
  mesh->vertices.emplace_back(x - size / 2, y - size / 2, z);
  mesh->vertices.emplace_back(x + size / 2, y - size / 2, z);
  mesh->vertices.emplace_back(x, y + size / 2, z);
  mesh->triangles.emplace_back(base, base + 1, base + 2);
}

// A wall at z = 4 seen by keyframe 0; keyframe 1 (0.5 to the side) owns the mesh. Seeing
// through a triangle (the wall clearly behind it) counts; the wall itself, what lies behind
// it, a triangle within the depth margin, or one behind the camera do not.
TEST(FreeSpaceViolations, AViewThatSeesTheWallBehindATriangleCountsIt) {
  const std::vector<DepthView> views = {ViewAt(0.0, 4.0, 4.0, 0), ViewAt(0.5, 0.0, 0.0, 0)};
  Mesh mesh;
  AddTriangle(&mesh, 0.0, 0.0, 4.0);   // 0: on the wall.
  AddTriangle(&mesh, 0.0, 0.0, 2.0);   // 1: floating halfway: seen through.
  AddTriangle(&mesh, 0.2, 0.1, 6.0);   // 2: behind the wall: occluded, not free space.
  AddTriangle(&mesh, 0.0, 0.0, 3.9);   // 3: 2.5 % in front: within the margin.
  AddTriangle(&mesh, 0.0, 0.0, -1.0);  // 4: behind keyframe 0.
  AddTriangle(&mesh, -0.3, 0.0, 3.0);  // 5: 25 % in front: seen through.
  AddTriangle(&mesh, 40.0, 0.0, 2.0);  // 6: outside keyframe 0's image.
  // 7: bridging from the wall to a surface at z = 2 (a rubber sheet over a discontinuity).
  mesh.vertices.emplace_back(-0.4, -0.3, 4.0);
  mesh.vertices.emplace_back(0.4, -0.3, 4.0);
  mesh.vertices.emplace_back(0.0, 0.3, 2.0);
  mesh.triangles.emplace_back(21, 22, 23);
  const Mesh none;
  const std::vector<const Mesh*> meshes = {&none, &mesh};
  const std::vector<std::vector<int>> v = FreeSpaceViolations(meshes, views, WalkMeshOptions{});
  ASSERT_EQ(v.size(), 2u);
  EXPECT_TRUE(v[0].empty());
  EXPECT_EQ(v[1], (std::vector<int>{0, 1, 0, 0, 0, 1, 0, 1}));
}

// A part's own keyframe never counts against it; views without a depth say nothing.
TEST(FreeSpaceViolations, OwnViewAndViewsWithoutDepthDoNotCount) {
  std::vector<DepthView> views = {ViewAt(0.0, 4.0, 4.0, 0), ViewAt(0.5, 4.0, 4.0, 0)};
  views[1].depth.reset();
  Mesh mesh;
  AddTriangle(&mesh, 0.0, 0.0, 2.0);
  const std::vector<const Mesh*> meshes = {&mesh, &mesh};
  const std::vector<std::vector<int>> v = FreeSpaceViolations(meshes, views, WalkMeshOptions{});
  EXPECT_EQ(v[0], std::vector<int>{0});  // Only keyframe 0 sees it through: its own.
  EXPECT_EQ(v[1], std::vector<int>{1});
}

// A near object (z = 2) left of column 32 before the wall (z = 4): a triangle on the object
// reaching a pixel past its edge in the view's image is not seen through (the 3x3 nearest
// depth), one a few pixels clear of the edge in front of the wall is.
TEST(FreeSpaceViolations, DepthEdgesDoNotReadAsSeeingThrough) {
  const std::vector<DepthView> views = {ViewAt(0.0, 2.0, 4.0, 32), ViewAt(0.5, 0.0, 0.0, 0)};
  // Column 32 is x = (32 - 31.5) / 50 * z at depth z.
  Mesh mesh;
  const double x_edge = 0.5 / 50 * 2.0;
  AddTriangle(&mesh, x_edge - 0.02, 0.0, 2.0, 0.08);  // On the object, straddling the edge.
  AddTriangle(&mesh, 0.4, 0.0, 2.0, 0.08);            // 10 pixels right: free space.
  const Mesh none;
  const std::vector<const Mesh*> meshes = {&none, &mesh};
  const std::vector<std::vector<int>> v = FreeSpaceViolations(meshes, views, WalkMeshOptions{});
  EXPECT_EQ(v[1], (std::vector<int>{0, 1}));
}

}  // namespace
}  // namespace mm
