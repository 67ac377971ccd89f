#include "recon/mesh.h"

#include <CGAL/Delaunay_triangulation_2.h>
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Triangulation_vertex_base_with_info_2.h>

#include <algorithm>

namespace mm {
namespace {

using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
using VertexBase = CGAL::Triangulation_vertex_base_with_info_2<int, Kernel>;
using Tds = CGAL::Triangulation_data_structure_2<VertexBase>;
using Delaunay = CGAL::Delaunay_triangulation_2<Kernel, Tds>;

}  // namespace

std::string MeshOptions::Check() const {
  if (max_depth_ratio != 0.0 && !(max_depth_ratio > 1.0)) {
    return "max_depth_ratio: must be 0 (off) or > 1";
  }
  return {};
}

Mesh BuildDelaunayMesh(std::span<const Eigen::Vector3d> points_in_cam_a,
                       std::span<const Eigen::Vector2d> pixels_in_a, int width, int height,
                       const MeshOptions& options, MeshSummary* summary) {
  Mesh mesh;
  MeshSummary local;
  local.input_points = static_cast<int>(points_in_cam_a.size());
  std::vector<std::pair<Kernel::Point_2, int>> sites;
  for (size_t i = 0; i < points_in_cam_a.size() && i < pixels_in_a.size(); ++i) {
    const Eigen::Vector2d& px = pixels_in_a[i];
    if (px.x() < 0 || px.y() < 0 || px.x() > width - 1 || px.y() > height - 1) continue;
    const int index = static_cast<int>(mesh.vertices.size());
    mesh.vertices.push_back(points_in_cam_a[i].cast<float>());
    mesh.uvs.emplace_back(static_cast<float>((px.x() + 0.5) / width),
                          static_cast<float>(1.0 - (px.y() + 0.5) / height));
    sites.emplace_back(Kernel::Point_2(px.x(), px.y()), index);
  }
  Delaunay dt;
  dt.insert(sites.begin(), sites.end());  // Duplicate sites collapse to one vertex.
  for (auto face = dt.finite_faces_begin(); face != dt.finite_faces_end(); ++face) {
    ++local.delaunay_triangles;
    const Eigen::Vector3i tri(face->vertex(0)->info(), face->vertex(1)->info(),
                              face->vertex(2)->info());
    if (options.max_depth_ratio > 0) {
      const float z0 = mesh.vertices[static_cast<size_t>(tri[0])].z();
      const float z1 = mesh.vertices[static_cast<size_t>(tri[1])].z();
      const float z2 = mesh.vertices[static_cast<size_t>(tri[2])].z();
      const float zmin = std::min({z0, z1, z2});
      const float zmax = std::max({z0, z1, z2});
      if (zmax > options.max_depth_ratio * zmin) {
        ++local.dropped_depth_discontinuity;
        continue;
      }
    }
    // CGAL orders faces counter-clockwise in (u, v); with v pointing down that is clockwise
    // on screen, so flip to make the faces front-facing (counter-clockwise) seen from A.
    mesh.triangles.emplace_back(tri[0], tri[2], tri[1]);
  }
  if (summary != nullptr) *summary = local;
  return mesh;
}

void ColorVerticesFromTexture(const cv::Mat& texture_bgr, Mesh* mesh) {
  CV_Assert(texture_bgr.type() == CV_8UC3);
  mesh->colors.clear();
  for (const Eigen::Vector2f& uv : mesh->uvs) {
    const int u = std::clamp(static_cast<int>(uv.x() * static_cast<float>(texture_bgr.cols)), 0,
                             texture_bgr.cols - 1);
    const int v = std::clamp(static_cast<int>((1.0f - uv.y()) * static_cast<float>(texture_bgr.rows)),
                             0, texture_bgr.rows - 1);
    const cv::Vec3b bgr = texture_bgr.at<cv::Vec3b>(v, u);
    mesh->colors.emplace_back(bgr[2], bgr[1], bgr[0]);
  }
}

}  // namespace mm
