#include "recon/mesh.h"

#include <CGAL/Delaunay_triangulation_2.h>
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Triangulation_vertex_base_with_info_2.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <numbers>
#include <unordered_map>

namespace mm {
namespace {

using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
using VertexBase = CGAL::Triangulation_vertex_base_with_info_2<int, Kernel>;
using Tds = CGAL::Triangulation_data_structure_2<VertexBase>;
using Delaunay = CGAL::Delaunay_triangulation_2<Kernel, Tds>;

// The q-quantile of v (v is reordered).
double Quantile(std::vector<double>* v, double q) {
  const size_t k = static_cast<size_t>(q * static_cast<double>(v->size() - 1));
  std::nth_element(v->begin(), v->begin() + static_cast<std::ptrdiff_t>(k), v->end());
  return (*v)[k];
}

// The largest 10-90 percentile range over x, y and z: the spread of the points, robust to
// a few far outliers.
double PointSpread(std::span<const Eigen::Vector3d> points) {
  double spread = 0.0;
  for (int axis = 0; axis < 3; ++axis) {
    std::vector<double> c;
    c.reserve(points.size());
    for (const Eigen::Vector3d& p : points) c.push_back(p[axis]);
    const double lo = Quantile(&c, 0.1);
    const double hi = Quantile(&c, 0.9);
    spread = std::max(spread, hi - lo);
  }
  return spread;
}

struct VoxelCell {
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  int count = 0;
  Eigen::Vector3i index = Eigen::Vector3i::Zero();
};

// Voxel grid (the thesis): one representative point per cell holding >= min points.
std::vector<Eigen::Vector3d> VoxelDownsample(std::span<const Eigen::Vector3d> points, double size,
                                             const MeshOptions& options, MeshSummary* summary) {
  std::unordered_map<uint64_t, VoxelCell> cells;
  std::vector<uint64_t> order;  // First-seen order: the output is deterministic.
  for (const Eigen::Vector3d& p : points) {
    const Eigen::Vector3i idx((p / size).array().floor().cast<int>());
    // 21 bits per axis, offset so that negative indices pack too.
    const uint64_t key = (static_cast<uint64_t>(idx.x() + (1 << 20)) & 0x1FFFFF) |
                         ((static_cast<uint64_t>(idx.y() + (1 << 20)) & 0x1FFFFF) << 21) |
                         ((static_cast<uint64_t>(idx.z() + (1 << 20)) & 0x1FFFFF) << 42);
    auto [it, inserted] = cells.try_emplace(key);
    if (inserted) {
      order.push_back(key);
      it->second.index = idx;
    }
    it->second.sum += p;
    ++it->second.count;
  }
  summary->occupied_cells = static_cast<int>(cells.size());
  std::vector<Eigen::Vector3d> out;
  for (uint64_t key : order) {
    const VoxelCell& cell = cells.at(key);
    if (cell.count < options.min_points_per_cell) continue;
    if (options.voxel_vertex == VoxelVertex::kCentroid) {
      out.push_back(cell.sum / cell.count);
    } else {
      out.push_back((cell.index.cast<double>().array() + 0.5).matrix() * size);
    }
  }
  summary->kept_cells = static_cast<int>(out.size());
  return out;
}

}  // namespace

std::string MeshOptions::Check() const {
  if (!std::isfinite(voxel_size)) return "voxel_size: must be finite";
  if (!(voxel_auto_fraction > 0.0 && voxel_auto_fraction <= 1.0)) {
    return "voxel_auto_fraction: must be in (0, 1]";
  }
  if (min_points_per_cell < 1) return "min_points_per_cell: must be >= 1";
  if (max_depth_ratio != 0.0 && !(max_depth_ratio > 1.0)) {
    return "max_depth_ratio: must be 0 (off) or > 1";
  }
  if (!(max_grazing_angle_deg >= 0.0 && max_grazing_angle_deg < 90.0)) {
    return "max_grazing_angle_deg: must be 0 (off) or in (0, 90)";
  }
  return {};
}

Eigen::Matrix3d FitCameraMatrix(std::span<const Eigen::Vector3d> points_in_cam,
                                std::span<const Eigen::Vector2d> pixels) {
  // u = fx x/z + s y/z + cx and v = fy y/z + cy are linear in (fx, s, cx) and (fy, cy).
  const size_t n = std::min(points_in_cam.size(), pixels.size());
  Eigen::MatrixXd Au(static_cast<Eigen::Index>(n), 3), Av(static_cast<Eigen::Index>(n), 2);
  Eigen::VectorXd bu(static_cast<Eigen::Index>(n)), bv(static_cast<Eigen::Index>(n));
  Eigen::Index rows = 0;
  for (size_t i = 0; i < n; ++i) {
    const Eigen::Vector3d& p = points_in_cam[i];
    if (!(p.z() > 0)) continue;
    Au.row(rows) << p.x() / p.z(), p.y() / p.z(), 1.0;
    Av.row(rows) << p.y() / p.z(), 1.0;
    bu(rows) = pixels[i].x();
    bv(rows) = pixels[i].y();
    ++rows;
  }
  Eigen::Matrix3d K = Eigen::Matrix3d::Identity();
  if (rows < 3) return K;
  const Eigen::Vector3d ku = Au.topRows(rows).colPivHouseholderQr().solve(bu.head(rows));
  const Eigen::Vector2d kv = Av.topRows(rows).colPivHouseholderQr().solve(bv.head(rows));
  K << ku[0], ku[1], ku[2], 0.0, kv[0], kv[1], 0.0, 0.0, 1.0;
  return K;
}

Mesh BuildDelaunayMesh(std::span<const Eigen::Vector3d> points_in_cam_a,
                       std::span<const Eigen::Vector2d> pixels_in_a, int width, int height,
                       const MeshOptions& options, MeshSummary* summary) {
  const size_t n = std::min(points_in_cam_a.size(), pixels_in_a.size());
  const Eigen::Matrix3d K = FitCameraMatrix(points_in_cam_a.first(n), pixels_in_a.first(n));
  return BuildDelaunayMesh(points_in_cam_a.first(n), K, width, height, options, summary);
}

Mesh BuildDelaunayMesh(std::span<const Eigen::Vector3d> points_in_cam_a, const Eigen::Matrix3d& K,
                       int width, int height, const MeshOptions& options, MeshSummary* summary) {
  Mesh mesh;
  MeshSummary local;
  local.input_points = static_cast<int>(points_in_cam_a.size());

  // Points in front of A that project into the image.
  std::vector<Eigen::Vector3d> inside;
  auto project = [&K](const Eigen::Vector3d& p) -> Eigen::Vector2d {
    return (K * p).hnormalized();
  };
  auto in_image = [width, height](const Eigen::Vector2d& px) {
    return px.x() >= 0 && px.y() >= 0 && px.x() <= width - 1 && px.y() <= height - 1;
  };
  for (const Eigen::Vector3d& p : points_in_cam_a) {
    if (p.z() > 0 && p.allFinite() && in_image(project(p))) inside.push_back(p);
  }
  local.points_in_image = static_cast<int>(inside.size());

  std::vector<Eigen::Vector3d> vertices;
  if (options.voxel_size >= 0 && inside.size() >= 3) {
    const double size = options.voxel_size > 0 ? options.voxel_size
                                               : options.voxel_auto_fraction * PointSpread(inside);
    if (size > 0) {
      local.voxel_size = size;
      vertices = VoxelDownsample(inside, size, options, &local);
    } else {
      vertices = inside;
    }
  } else {
    vertices = inside;
  }

  std::vector<std::pair<Kernel::Point_2, int>> sites;
  for (const Eigen::Vector3d& v : vertices) {
    const Eigen::Vector2d px = project(v);
    if (!(v.z() > 0) || !in_image(px)) continue;  // A cell centre can fall outside.
    const int index = static_cast<int>(mesh.vertices.size());
    mesh.vertices.push_back(v.cast<float>());
    mesh.uvs.emplace_back(static_cast<float>((px.x() + 0.5) / width),
                          static_cast<float>(1.0 - (px.y() + 0.5) / height));
    sites.emplace_back(Kernel::Point_2(px.x(), px.y()), index);
  }
  local.vertices = static_cast<int>(mesh.vertices.size());

  Delaunay dt;
  dt.insert(sites.begin(), sites.end());  // Duplicate sites collapse to one vertex.
  const double cos_grazing =
      options.max_grazing_angle_deg > 0
          ? std::cos(options.max_grazing_angle_deg * std::numbers::pi / 180.0)
          : -1.0;
  for (auto face = dt.finite_faces_begin(); face != dt.finite_faces_end(); ++face) {
    ++local.delaunay_triangles;
    const Eigen::Vector3i tri(face->vertex(0)->info(), face->vertex(1)->info(),
                              face->vertex(2)->info());
    const Eigen::Vector3f& p0 = mesh.vertices[static_cast<size_t>(tri[0])];
    const Eigen::Vector3f& p1 = mesh.vertices[static_cast<size_t>(tri[1])];
    const Eigen::Vector3f& p2 = mesh.vertices[static_cast<size_t>(tri[2])];
    if (options.max_depth_ratio > 0) {
      const float zmin = std::min({p0.z(), p1.z(), p2.z()});
      const float zmax = std::max({p0.z(), p1.z(), p2.z()});
      if (zmax > options.max_depth_ratio * zmin) {
        ++local.dropped_depth_discontinuity;
        continue;
      }
    }
    if (cos_grazing > 0) {
      // Angle between the face normal and the viewing ray to the centroid.
      const Eigen::Vector3d n = (p1 - p0).cross(p2 - p0).cast<double>();
      const Eigen::Vector3d ray = ((p0 + p1 + p2) / 3.0f).cast<double>();
      const double denom = n.norm() * ray.norm();
      if (!(denom > 0) || std::abs(n.dot(ray)) < cos_grazing * denom) {
        ++local.dropped_grazing_angle;
        continue;
      }
    }
    // CGAL orders faces counter-clockwise in (u, v); with v pointing down that is clockwise
    // on screen, so flip to make the faces front-facing (counter-clockwise) seen from A.
    mesh.triangles.emplace_back(tri[0], tri[2], tri[1]);
  }
  local.triangles = static_cast<int>(mesh.triangles.size());
  if (summary != nullptr) *summary = local;
  return mesh;
}

void ColorVerticesFromTexture(const cv::Mat& texture_bgr, Mesh* mesh) {
  CV_Assert(texture_bgr.type() == CV_8UC3);
  mesh->colors.clear();
  for (const Eigen::Vector2f& uv : mesh->uvs) {
    const int u = std::clamp(static_cast<int>(uv.x() * static_cast<float>(texture_bgr.cols)), 0,
                             texture_bgr.cols - 1);
    const int v =
        std::clamp(static_cast<int>((1.0f - uv.y()) * static_cast<float>(texture_bgr.rows)), 0,
                   texture_bgr.rows - 1);
    const cv::Vec3b bgr = texture_bgr.at<cv::Vec3b>(v, u);
    mesh->colors.emplace_back(bgr[2], bgr[1], bgr[0]);
  }
}

}  // namespace mm
