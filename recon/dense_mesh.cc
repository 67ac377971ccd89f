#include "recon/dense_mesh.h"

#include <Eigen/Dense>
#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>
#include <queue>
#include <unordered_set>
#include <vector>

namespace mm {
namespace {

struct QuadCell {
  int x = 0, y = 0, size = 0;
  double priority = 0;  // How much a split is wanted; < 0 = a leaf for good.
  bool operator<(const QuadCell& other) const { return priority < other.priority; }
};

// The cell's corners, clamped to the image.
struct Corners {
  int x0, y0, x1, y1;
  [[nodiscard]] std::array<std::pair<int, int>, 4> Pixels() const {
    return {{{x0, y0}, {x1, y0}, {x0, y1}, {x1, y1}}};
  }
};

Corners CornersOf(const QuadCell& c, int width, int height) {
  return {std::min(c.x, width - 1), std::min(c.y, height - 1), std::min(c.x + c.size, width - 1),
          std::min(c.y + c.size, height - 1)};
}

// How much the cell wants a split: its largest relative departure from the bilinear
// interpolation of its corners' inverse depths, `mixed_priority` when it holds pixels with and
// without depth, -1 when it has no depth at all.
double SplitPriority(const DenseDepth& depth, const QuadCell& cell, int width, int height,
                     double mixed_priority, double noise) {
  const Corners k = CornersOf(cell, width, height);
  const double r00 = InverseDepthAt(depth, k.x0, k.y0), r10 = InverseDepthAt(depth, k.x1, k.y0);
  const double r01 = InverseDepthAt(depth, k.x0, k.y1), r11 = InverseDepthAt(depth, k.x1, k.y1);
  int with = (r00 > 0) + (r10 > 0) + (r01 > 0) + (r11 > 0), without = 4 - with;
  double worst = 0;
  const int step = std::max(1, depth.downscale);
  const double w = std::max(1, k.x1 - k.x0), h = std::max(1, k.y1 - k.y0);
  for (int y = k.y0; y <= k.y1; y += step) {
    for (int x = k.x0; x <= k.x1; x += step) {
      const double rho = InverseDepthAt(depth, x, y);
      if (!(rho > 0)) {
        ++without;
        continue;
      }
      ++with;
      if (without > 0) continue;
      const double fx = (x - k.x0) / w, fy = (y - k.y0) / h;
      const double interp =
          (1 - fy) * ((1 - fx) * r00 + fx * r10) + fy * ((1 - fx) * r01 + fx * r11);
      worst = std::max(worst, std::max(0.0, std::abs(rho - interp) - noise) / rho);
    }
  }
  if (with == 0) return -1;
  if (without > 0) return mixed_priority;
  return worst;
}

}  // namespace

std::string DenseMeshOptions::Check() const {
  auto power_of_two = [](int v) { return v > 0 && (v & (v - 1)) == 0; };
  if (!power_of_two(max_cell_px) || !power_of_two(min_cell_px) || min_cell_px < 2 ||
      max_cell_px < min_cell_px || max_cell_px > 256) {
    return "mesh cells must be powers of two with 2 <= min_cell_px <= max_cell_px <= 256";
  }
  if (!(max_cell_deviation > 0 && max_cell_deviation < 1))
    return "mesh.max_cell_deviation must be in (0, 1)";
  if (vertex_budget < 16 || vertex_budget > 1000000)
    return "mesh.vertex_budget must be in [16, 1000000]";
  if (!(max_triangle_deviation > 0 && max_triangle_deviation < 1)) {
    return "mesh.max_triangle_deviation must be in (0, 1)";
  }
  if (!(max_slant_deg > 0 && max_slant_deg < 90)) return "mesh.max_slant_deg must be in (0, 90)";
  if (!(noise_planes >= 0 && noise_planes <= 16)) return "mesh.noise_planes must be in [0, 16]";
  return {};
}

Mesh BuildDenseMesh(const DenseDepth& depth, const Eigen::Matrix3d& K, int width, int height,
                    const DenseMeshOptions& options, DenseMeshSummary* summary) {
  DenseMeshSummary local;
  Mesh mesh;
  if (!depth.success || !options.Check().empty() || width < 2 || height < 2) {
    if (summary != nullptr) *summary = local;
    return mesh;
  }
  // Quadtree, the cell that most wants a split first, until the budget. Each split adds at
  // most five corners.
  const double mixed_priority = 4 * options.max_cell_deviation;
  const double noise = options.noise_planes * depth.inverse_depth_step;
  std::priority_queue<QuadCell> open;
  std::vector<QuadCell> leaves;
  std::unordered_set<long> corners;
  auto add_corners = [&](const QuadCell& c) {
    for (const auto& [x, y] : CornersOf(c, width, height).Pixels()) {
      corners.insert(static_cast<long>(y) * width + x);
    }
  };
  auto push = [&](QuadCell c) {
    c.priority = SplitPriority(depth, c, width, height, mixed_priority, noise);
    if (c.priority < 0) return;  // No depth: no vertices, no triangles.
    add_corners(c);
    if (c.size <= options.min_cell_px || c.priority <= options.max_cell_deviation) {
      leaves.push_back(c);
    } else {
      open.push(c);
    }
  };
  for (int y = 0; y < height - 1; y += options.max_cell_px) {
    for (int x = 0; x < width - 1; x += options.max_cell_px) push({x, y, options.max_cell_px, 0});
  }
  while (!open.empty()) {
    const QuadCell c = open.top();
    open.pop();
    if (static_cast<int>(corners.size()) + 5 > options.vertex_budget) {
      local.budget_reached = true;
      leaves.push_back(c);
      continue;
    }
    const int half = c.size / 2;
    for (int j = 0; j < 2; ++j) {
      for (int i = 0; i < 2; ++i) {
        const QuadCell child{c.x + i * half, c.y + j * half, half, 0};
        if (child.x < width - 1 && child.y < height - 1) push(child);
      }
    }
  }
  local.leaf_cells = static_cast<int>(leaves.size());

  // The leaf corners with a depth, lifted into A's frame.
  std::unordered_set<long> seen;
  std::vector<Eigen::Vector3d> points;
  const Eigen::Matrix3d K_inv = K.inverse();
  for (const QuadCell& c : leaves) {
    for (const auto& [x, y] : CornersOf(c, width, height).Pixels()) {
      if (!seen.insert(static_cast<long>(y) * width + x).second) continue;
      const double rho = InverseDepthAt(depth, x, y);
      if (rho > 0) points.push_back(K_inv * Eigen::Vector3d(x, y, 1.0) / rho);
    }
  }
  MeshOptions delaunay;
  delaunay.voxel_size = -1;  // Every corner is a vertex.
  delaunay.max_depth_ratio = 0;
  delaunay.max_grazing_angle_deg = 0;
  MeshSummary delaunay_summary;
  Mesh all = BuildDelaunayMesh(points, K, width, height, delaunay, &delaunay_summary);
  local.delaunay_triangles = delaunay_summary.triangles;

  // The triangle checks, in pixels of A and inverse depth (affine over a plane's image).
  const double tan_slant = std::tan(options.max_slant_deg * std::numbers::pi / 180.0);
  const double focal = 0.5 * (K(0, 0) + K(1, 1));
  auto pixel_of = [&](const Eigen::Vector2f& uv) {
    return Eigen::Vector2d(uv.x() * width - 0.5, (1.0 - uv.y()) * height - 0.5);
  };
  std::vector<int> remap(all.vertices.size(), -1);
  for (const Eigen::Vector3i& tri : all.triangles) {
    Eigen::Vector2d px[3];
    double rho[3];
    for (int i = 0; i < 3; ++i) {
      px[i] = pixel_of(all.uvs[static_cast<size_t>(tri[i])]);
      rho[i] = 1.0 / all.vertices[static_cast<size_t>(tri[i])].z();
    }
    const double longest =
        std::max({(px[0] - px[1]).norm(), (px[1] - px[2]).norm(), (px[2] - px[0]).norm()});
    const double rho_max = std::max({rho[0], rho[1], rho[2]});
    const double rho_min = std::min({rho[0], rho[1], rho[2]});
    if (rho_max - rho_min > rho_min * longest / focal * tan_slant + 2 * noise) {
      ++local.dropped_discontinuity;
      continue;
    }
    // Centroid and edge midpoints: (weights of the three corners).
    constexpr double kSamples[4][3] = {
        {1.0 / 3, 1.0 / 3, 1.0 / 3}, {0.5, 0.5, 0}, {0, 0.5, 0.5}, {0.5, 0, 0.5}};
    bool no_depth = false, bridging = false;
    for (const auto& w : kSamples) {
      const Eigen::Vector2d p = w[0] * px[0] + w[1] * px[1] + w[2] * px[2];
      const double measured = InverseDepthAt(depth, p.x(), p.y());
      if (!(measured > 0)) {
        no_depth = true;
        break;
      }
      const double own = w[0] * rho[0] + w[1] * rho[1] + w[2] * rho[2];
      if (std::abs(measured - own) > options.max_triangle_deviation * measured + noise) {
        bridging = true;
      }
    }
    if (no_depth) {
      ++local.dropped_no_depth;
      continue;
    }
    if (bridging) {
      ++local.dropped_bridging;
      continue;
    }
    Eigen::Vector3i kept;
    for (int i = 0; i < 3; ++i) {
      int& index = remap[static_cast<size_t>(tri[i])];
      if (index < 0) {
        index = static_cast<int>(mesh.vertices.size());
        mesh.vertices.push_back(all.vertices[static_cast<size_t>(tri[i])]);
        mesh.uvs.push_back(all.uvs[static_cast<size_t>(tri[i])]);
      }
      kept[i] = index;
    }
    mesh.triangles.push_back(kept);
  }
  local.vertices = static_cast<int>(mesh.vertices.size());
  local.triangles = static_cast<int>(mesh.triangles.size());
  if (summary != nullptr) *summary = local;
  return mesh;
}

}  // namespace mm
