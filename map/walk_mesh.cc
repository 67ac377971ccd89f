#include "map/walk_mesh.h"

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <map>
#include <numbers>
#include <optional>
#include <span>
#include <utility>

#include "base/stats.h"

namespace mm {
namespace {

// Whether `x_segment` lies on the surface `view` saw (within `rel` in depth).
bool SeenBy(const DepthView& view, const Eigen::Matrix3d& K, int width, int height,
            const Eigen::Vector3d& x_segment, double rel) {
  if (!view.depth) return false;
  const Eigen::Vector3d x = view.cam_from_segment * x_segment;
  if (x.z() <= 0) return false;
  const Eigen::Vector3d p = K * x;
  const double u = p.x() / p.z(), v = p.y() / p.z();
  if (u < 0 || v < 0 || u > width - 1 || v > height - 1) return false;
  const double inverse_depth = InverseDepthAt(*view.depth, u, v);
  if (inverse_depth <= 0) return false;
  return std::abs(x.z() * inverse_depth - 1.0) <= rel;
}

// The depth uncertainty of `view` at `x_segment`: its sweep's plane spacing in inverse depth
// times z^2 (a plane sweep resolves inverse depth evenly), infinite without a depth.
double DepthSigma(const DepthView& view, const Eigen::Vector3d& x_segment) {
  if (!view.depth) return std::numeric_limits<double>::infinity();
  const double z = (view.cam_from_segment * x_segment).z();
  return z * z * view.depth->inverse_depth_step;
}

Eigen::Vector3d CentroidOf(const Mesh& mesh, size_t t) {
  const Eigen::Vector3i& tri = mesh.triangles[t];
  return ((mesh.vertices[static_cast<size_t>(tri[0])] + mesh.vertices[static_cast<size_t>(tri[1])] +
           mesh.vertices[static_cast<size_t>(tri[2])]) /
          3.0f)
      .cast<double>();
}

// Keeps the triangles flagged and the vertices they use.
void KeepTriangles(const std::vector<char>& keep, Mesh* mesh) {
  std::vector<int> new_index(mesh->vertices.size(), -1);
  Mesh out;
  for (size_t t = 0; t < mesh->triangles.size(); ++t) {
    if (!keep[t]) continue;
    Eigen::Vector3i tri;
    for (int c = 0; c < 3; ++c) {
      const auto v = static_cast<size_t>(mesh->triangles[t][c]);
      if (new_index[v] < 0) {
        new_index[v] = static_cast<int>(out.vertices.size());
        out.vertices.push_back(mesh->vertices[v]);
        if (!mesh->uvs.empty()) out.uvs.push_back(mesh->uvs[v]);
        if (!mesh->colors.empty()) out.colors.push_back(mesh->colors[v]);
      }
      tri[c] = new_index[v];
    }
    out.triangles.push_back(tri);
  }
  *mesh = std::move(out);
}

// The vertices in a view's image through `K`: pixel and inverse depth (0 behind the camera).
std::vector<Eigen::Vector3d> ProjectVertices(const Mesh& mesh,
                                             const Eigen::Isometry3d& cam_from_segment,
                                             const Eigen::Matrix3d& K) {
  std::vector<Eigen::Vector3d> projected(mesh.vertices.size(), Eigen::Vector3d::Zero());
  for (size_t i = 0; i < mesh.vertices.size(); ++i) {
    const Eigen::Vector3d x = cam_from_segment * mesh.vertices[i].cast<double>();
    if (x.z() <= 0) continue;
    const Eigen::Vector3d p = K * x;
    projected[i] = Eigen::Vector3d(p.x() / p.z(), p.y() / p.z(), 1.0 / x.z());
  }
  return projected;
}

// Calls on_pixel(x, y, inverse depth) at the pixel centres of a cols x rows image inside the
// triangle (at its centroid's pixel when it covers none) until it returns true, and returns
// whether it did. The inverse depth of a plane is affine in the image: the triangle's is the
// barycentric blend of its corners'. A triangle crossing the camera plane is skipped.
template <typename OnPixel>
bool RasterizeTriangle(const std::vector<Eigen::Vector3d>& projected, const Eigen::Vector3i& tri,
                       int cols, int rows, OnPixel&& on_pixel) {
  const Eigen::Vector3d& a = projected[static_cast<size_t>(tri[0])];
  const Eigen::Vector3d& b = projected[static_cast<size_t>(tri[1])];
  const Eigen::Vector3d& c = projected[static_cast<size_t>(tri[2])];
  if (a.z() <= 0 || b.z() <= 0 || c.z() <= 0) return false;
  const double area = (b.x() - a.x()) * (c.y() - a.y()) - (b.y() - a.y()) * (c.x() - a.x());
  bool covers_a_pixel = false;
  if (std::abs(area) > 1e-12) {
    const int x0 = std::max(0, static_cast<int>(std::ceil(std::min({a.x(), b.x(), c.x()}))));
    const int x1 =
        std::min(cols - 1, static_cast<int>(std::floor(std::max({a.x(), b.x(), c.x()}))));
    const int y0 = std::max(0, static_cast<int>(std::ceil(std::min({a.y(), b.y(), c.y()}))));
    const int y1 =
        std::min(rows - 1, static_cast<int>(std::floor(std::max({a.y(), b.y(), c.y()}))));
    for (int y = y0; y <= y1; ++y) {
      for (int x = x0; x <= x1; ++x) {
        const double wa = ((b.x() - x) * (c.y() - y) - (b.y() - y) * (c.x() - x)) / area;
        const double wb = ((c.x() - x) * (a.y() - y) - (c.y() - y) * (a.x() - x)) / area;
        const double wc = 1.0 - wa - wb;
        if (wa < 0 || wb < 0 || wc < 0) continue;
        covers_a_pixel = true;
        if (on_pixel(x, y, wa * a.z() + wb * b.z() + wc * c.z())) return true;
      }
    }
  }
  if (covers_a_pixel) return false;
  const Eigen::Vector3d m = (a + b + c) / 3.0;
  const int u = static_cast<int>(std::lround(m.x())), v = static_cast<int>(std::lround(m.y()));
  return u >= 0 && v >= 0 && u < cols && v < rows && on_pixel(u, v, m.z());
}

// The inverse depth of `mesh` (segment frame) in `view`'s shrunk image, nearest surface first:
// what the part holds, for the redundancy test.
cv::Mat HeldInverseDepth(const Mesh& mesh, const DepthView& view) {
  const DenseDepth& d = *view.depth;
  cv::Mat held(d.inverse_depth.size(), CV_32FC1, cv::Scalar(0));
  const std::vector<Eigen::Vector3d> projected = ProjectVertices(mesh, view.cam_from_segment, d.K);
  for (const Eigen::Vector3i& tri : mesh.triangles) {
    RasterizeTriangle(projected, tri, held.cols, held.rows, [&](int x, int y, double rho) {
      float& h = held.at<float>(y, x);
      h = std::max(h, static_cast<float>(rho));
      return false;
    });
  }
  return held;
}

// The part keyframe k's stereo views (WalkMeshOptions::stereo_neighbours): its neighbours in the
// segment that see most of k's points (`point_ids`) inside their image, widest median
// triangulation angle first, up to the cap; the first is the partner (it sets the sweep's
// planes). None qualifies: the keyframe before k (after it for the first). Empty: a segment of
// one keyframe.
std::vector<int> StereoViews(const std::vector<WalkKeyframe>& keyframes,
                             const std::vector<WalkPoint>& points,
                             const std::vector<int>& point_ids, const std::vector<int>& members,
                             int k, const Eigen::Matrix3d& K, int width, int height,
                             const WalkMeshOptions& options) {
  const auto it = std::find(members.begin(), members.end(), k);
  const auto at = static_cast<int>(it - members.begin());
  const Eigen::Vector3d centre_k =
      keyframes[static_cast<size_t>(k)].cam_from_segment.inverse().translation();
  const double max_angle = options.max_stereo_angle_deg * std::numbers::pi / 180.0;
  std::vector<std::pair<double, int>> ranked;  // (-angle, keyframe)
  for (int d = -options.stereo_neighbours; d <= options.stereo_neighbours; ++d) {
    const int m = at + d;
    if (d == 0 || m < 0 || m >= static_cast<int>(members.size()) || point_ids.empty()) continue;
    const int c = members[static_cast<size_t>(m)];
    const Eigen::Isometry3d& c_from_segment = keyframes[static_cast<size_t>(c)].cam_from_segment;
    const Eigen::Vector3d centre_c = c_from_segment.inverse().translation();
    std::vector<double> angles;
    for (int id : point_ids) {
      const Eigen::Vector3d& x = points[static_cast<size_t>(id)].position_in_segment;
      const Eigen::Vector3d p = K * (c_from_segment * x);
      if (p.z() <= 0) continue;
      const double u = p.x() / p.z(), v = p.y() / p.z();
      if (u < 0 || v < 0 || u >= width || v >= height) continue;
      const Eigen::Vector3d a = x - centre_k, b = x - centre_c;
      angles.push_back(std::acos(std::clamp(a.dot(b) / (a.norm() * b.norm()), -1.0, 1.0)));
    }
    if (static_cast<double>(angles.size()) <
        options.min_stereo_overlap * static_cast<double>(point_ids.size())) {
      continue;
    }
    const double angle = MedianOf(std::move(angles));
    if (angle <= max_angle) ranked.emplace_back(-angle, c);
  }
  std::sort(ranked.begin(), ranked.end());
  std::vector<int> views;
  for (const auto& [negative_angle, c] : ranked) {
    if (static_cast<int>(views.size()) > options.stereo_extra_views) break;
    views.push_back(c);
  }
  if (views.empty() && members.size() > 1) {
    views.push_back(it == members.begin() ? members[1] : *(it - 1));
  }
  return views;
}

}  // namespace

std::string WalkMeshOptions::Check() const {
  if (std::string p = depth.Check(); !p.empty()) return "depth." + p;
  if (std::string p = dense_mesh.Check(); !p.empty()) return "dense_mesh." + p;
  if (std::string p = sparse.Check(); !p.empty()) return "sparse." + p;
  if (!(max_shared_points >= 0 && max_shared_points <= 1)) {
    return "max_shared_points: must be in [0, 1]";
  }
  if (max_parts < 1) return "max_parts: must be >= 1";
  if (stereo_neighbours < 1) return "stereo_neighbours: must be >= 1";
  if (stereo_extra_views < 0) return "stereo_extra_views: must be >= 0";
  if (!(max_stereo_angle_deg > 0)) return "max_stereo_angle_deg: must be > 0";
  if (!(min_stereo_overlap >= 0 && min_stereo_overlap <= 1)) {
    return "min_stereo_overlap: must be in [0, 1]";
  }
  if (overlap_parts < 0) return "overlap_parts: must be >= 0";
  if (!(overlap_depth_rel >= 0)) return "overlap_depth_rel: must be >= 0";
  if (free_space_min_views < 0) return "free_space_min_views: must be >= 0";
  if (!(free_space_depth_rel >= 0)) return "free_space_depth_rel: must be >= 0";
  if (!(free_space_noise_planes >= 0)) return "free_space_noise_planes: must be >= 0";
  return {};
}

std::vector<std::vector<int>> FreeSpaceViolations(std::span<const Mesh* const> meshes,
                                                  std::span<const DepthView> views,
                                                  const WalkMeshOptions& options) {
  std::vector<std::vector<int>> violations(meshes.size());
  for (size_t p = 0; p < meshes.size(); ++p) violations[p].assign(meshes[p]->triangles.size(), 0);
  for (size_t q = 0; q < views.size(); ++q) {
    if (!views[q].depth) continue;
    const DenseDepth& d = *views[q].depth;
    // The view's nearest depth around each pixel (the largest inverse depth of the 3x3
    // window): a depth edge or a pixel of pose error never reads as seeing through.
    cv::Mat nearest;
    cv::dilate(d.inverse_depth, nearest, cv::Mat());
    const double margin = options.free_space_noise_planes * d.inverse_depth_step;
    const auto sees_through = [&](int x, int y, double rho) {
      const float n = nearest.at<float>(y, x);
      return n > 0 && rho > n * (1.0 + options.free_space_depth_rel) + margin;
    };
    for (size_t p = 0; p < meshes.size(); ++p) {
      if (p == q) continue;
      const Mesh& mesh = *meshes[p];
      const std::vector<Eigen::Vector3d> projected =
          ProjectVertices(mesh, views[q].cam_from_segment, d.K);
      for (size_t t = 0; t < mesh.triangles.size(); ++t) {
        if (RasterizeTriangle(projected, mesh.triangles[t], nearest.cols, nearest.rows,
                              sees_through)) {
          ++violations[p][t];
        }
      }
    }
  }
  return violations;
}

Mesh WalkMesh::Merged() const {
  Mesh out;
  for (const WalkMeshPart& part : parts) {
    const int base = static_cast<int>(out.vertices.size());
    out.vertices.insert(out.vertices.end(), part.mesh.vertices.begin(), part.mesh.vertices.end());
    out.colors.insert(out.colors.end(), part.mesh.colors.begin(), part.mesh.colors.end());
    out.colors.resize(out.vertices.size(), Eigen::Matrix<uint8_t, 3, 1>(128, 128, 128));
    for (const Eigen::Vector3i& t : part.mesh.triangles) {
      out.triangles.push_back(t + Eigen::Vector3i::Constant(base));
    }
  }
  return out;
}

int LargestSegment(const WalkMap& map) {
  std::map<int, int> size;
  for (const WalkKeyframe& k : map.keyframes()) {
    if (k.registered) ++size[k.segment];
  }
  int best = -1, best_size = 0;
  for (const auto& [segment, n] : size) {
    if (n > best_size) best = segment, best_size = n;
  }
  return best;
}

WalkMesh BuildWalkMesh(const WalkMap& map, int segment, const Eigen::Matrix3d& K,
                       const KeyframeImageFn& image_of, const WalkMeshOptions& options) {
  const auto start = std::chrono::steady_clock::now();
  WalkMesh out;
  WalkMeshSummary& s = out.summary;
  s.segment = segment;
  const std::vector<WalkKeyframe>& keyframes = map.keyframes();
  const std::vector<WalkPoint>& points = map.points();
  std::vector<int> members;
  for (size_t i = 0; i < keyframes.size(); ++i) {
    if (keyframes[i].registered && keyframes[i].segment == segment) {
      members.push_back(static_cast<int>(i));
    }
  }
  s.segment_keyframes = static_cast<int>(members.size());
  if (members.empty()) return out;

  // The map points a keyframe observes.
  const auto points_of = [&](int k) {
    std::vector<int> ids;
    for (int id : keyframes[static_cast<size_t>(k)].point_of_keypoint) {
      if (id >= 0 && points[static_cast<size_t>(id)].valid) ids.push_back(id);
    }
    return ids;
  };
  // Part keyframes: a new view when the last part's keyframe sees few of its points.
  std::vector<int> chosen{members.front()};
  for (size_t m = 1; m < members.size(); ++m) {
    const std::vector<int> ids = points_of(members[m]);
    if (ids.empty()) continue;
    int shared = 0;
    for (int id : ids) {
      for (const WalkPoint::Observation& o : points[static_cast<size_t>(id)].observations) {
        if (o.keyframe == chosen.back()) {
          ++shared;
          break;
        }
      }
    }
    if (shared <= options.max_shared_points * static_cast<double>(ids.size())) {
      chosen.push_back(members[m]);
    }
  }
  if (static_cast<int>(chosen.size()) > options.max_parts) {
    std::vector<int> even;
    even.reserve(static_cast<size_t>(options.max_parts));
    for (int i = 0; i < options.max_parts; ++i) {
      even.push_back(chosen[static_cast<size_t>(i) * (chosen.size() - 1) /
                            static_cast<size_t>(std::max(options.max_parts - 1, 1))]);
    }
    chosen = even;
  }

  // Pass 1: every part's mesh (in the segment's frame) and its keyframe's depth.
  std::vector<WalkMeshPart> parts;
  std::vector<DepthView> views;
  int width = 0, height = 0;
  for (int k : chosen) {
    const WalkKeyframe& keyframe = keyframes[static_cast<size_t>(k)];
    const cv::Mat image = image_of(k);
    if (image.empty()) continue;
    width = image.cols, height = image.rows;
    cv::Mat gray;
    cv::cvtColor(image, gray, cv::COLOR_BGR2GRAY);
    const std::vector<int> point_ids = points_of(k);
    std::vector<Eigen::Vector3d> points_in_cam;
    points_in_cam.reserve(point_ids.size());
    for (int id : point_ids) {
      points_in_cam.push_back(keyframe.cam_from_segment *
                              points[static_cast<size_t>(id)].position_in_segment);
    }
    WalkMeshPart part;
    part.keyframe = k;
    DepthView view{keyframe.cam_from_segment, std::nullopt};
    if (options.dense) {
      // The partner and the further views, each as grey image and pose from this keyframe.
      std::vector<DenseView> stereo;
      for (int c :
           StereoViews(keyframes, points, point_ids, members, k, K, width, height, options)) {
        const cv::Mat c_image = image_of(c);
        if (c_image.empty()) continue;
        DenseView v;
        cv::cvtColor(c_image, v.gray, cv::COLOR_BGR2GRAY);
        const Eigen::Isometry3d c_from_cam = keyframes[static_cast<size_t>(c)].cam_from_segment *
                                             keyframe.cam_from_segment.inverse();
        v.rotation_from_a = c_from_cam.linear();
        v.translation_from_a = c_from_cam.translation();
        stereo.push_back(std::move(v));
      }
      if (!stereo.empty()) {
        const DenseView& partner = stereo.front();
        DenseDepth depth = ComputeDenseDepth(
            gray, partner.gray, K, partner.rotation_from_a, partner.translation_from_a,
            points_in_cam, options.depth, std::span<const DenseView>(stereo).subspan(1));
        if (depth.success) {
          part.mesh = BuildDenseMesh(depth, K, image.cols, image.rows, options.dense_mesh);
          part.dense = !part.mesh.triangles.empty();
          if (part.dense) {
            depth.confidence.release();  // Only the inverse depth is read from here on.
            view.depth = std::move(depth);
          }
        }
      }
    }
    if (!part.dense) {
      part.mesh = BuildDelaunayMesh(points_in_cam, K, image.cols, image.rows, options.sparse);
    }
    ColorVerticesFromTexture(image, &part.mesh);
    // Into the segment's frame.
    const Eigen::Isometry3f segment_from_cam = keyframe.cam_from_segment.inverse().cast<float>();
    for (Eigen::Vector3f& v : part.mesh.vertices) v = segment_from_cam * v;
    parts.push_back(std::move(part));
    views.push_back(std::move(view));
  }

  // Pass 2, visibility: every part's triangles against every other part's depth.
  std::vector<std::vector<char>> keep(parts.size());
  std::vector<const Mesh*> meshes;
  for (size_t p = 0; p < parts.size(); ++p) {
    keep[p].assign(parts[p].mesh.triangles.size(), 1);
    meshes.push_back(&parts[p].mesh);
  }
  if (options.free_space_min_views > 0) {
    const std::vector<std::vector<int>> violations = FreeSpaceViolations(meshes, views, options);
    for (size_t p = 0; p < parts.size(); ++p) {
      for (size_t t = 0; t < violations[p].size(); ++t) {
        if (violations[p][t] >= options.free_space_min_views) {
          keep[p][t] = 0;
          ++parts[p].dropped_free_space;
        }
      }
      if (parts[p].dropped_free_space == 0) continue;
      KeepTriangles(keep[p], &parts[p].mesh);
      keep[p].assign(parts[p].mesh.triangles.size(), 1);
    }
  }
  // What a part holds from here on: the depth of the triangles it kept (not its keyframe's
  // depth map, which also has the surfaces its mesh dropped or never had).
  for (size_t p = 0; p < parts.size(); ++p) {
    if (views[p].depth) views[p].depth->inverse_depth = HeldInverseDepth(parts[p].mesh, views[p]);
  }
  // Pass 3, redundancy: a surface that several parts within `overlap_parts` of each other
  // hold is kept by the one that measured it most precisely (the earlier on a tie).
  const size_t window = static_cast<size_t>(options.overlap_parts);
  for (size_t p = 0; p < parts.size(); ++p) {
    WalkMeshPart& part = parts[p];
    const size_t first = p > window ? p - window : 0;
    const size_t last = std::min(p + window, parts.size() - 1);
    for (size_t t = 0; t < keep[p].size() && first < last; ++t) {
      const Eigen::Vector3d centroid = CentroidOf(part.mesh, t);
      const double own = DepthSigma(views[p], centroid);
      for (size_t q = first; q <= last; ++q) {
        if (q == p) continue;
        const double other = DepthSigma(views[q], centroid);
        if (other > own || (other == own && q > p)) continue;
        if (SeenBy(views[q], K, width, height, centroid, options.overlap_depth_rel)) {
          keep[p][t] = 0;
          ++part.dropped_overlap;
          break;
        }
      }
    }
    if (part.dropped_overlap > 0) KeepTriangles(keep[p], &part.mesh);
    s.dropped_overlap += part.dropped_overlap;
    s.dropped_free_space += part.dropped_free_space;
    if (part.mesh.triangles.empty()) continue;
    ++(part.dense ? s.dense_parts : s.sparse_parts);
    s.vertices += static_cast<int>(part.mesh.vertices.size());
    s.triangles += static_cast<int>(part.mesh.triangles.size());
    out.parts.push_back(std::move(part));
  }
  s.parts = static_cast<int>(out.parts.size());
  s.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return out;
}

}  // namespace mm
