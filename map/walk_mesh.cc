#include "map/walk_mesh.h"

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <map>
#include <optional>

namespace mm {
namespace {

// A part's keyframe as later parts see it: pose and dense depth (when the part is dense).
struct PartView {
  Eigen::Isometry3d cam_from_segment;
  std::optional<DenseDepth> depth;
};

// Whether `x_segment` lies on the surface `view` saw (within `rel` in depth).
bool SeenBy(const PartView& view, const Eigen::Matrix3d& K, int width, int height,
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

}  // namespace

std::string WalkMeshOptions::Check() const {
  if (std::string p = depth.Check(); !p.empty()) return "depth." + p;
  if (std::string p = dense_mesh.Check(); !p.empty()) return "dense_mesh." + p;
  if (std::string p = sparse.Check(); !p.empty()) return "sparse." + p;
  if (!(max_shared_points >= 0 && max_shared_points <= 1)) {
    return "max_shared_points: must be in [0, 1]";
  }
  if (max_parts < 1) return "max_parts: must be >= 1";
  if (overlap_parts < 0) return "overlap_parts: must be >= 0";
  if (!(overlap_depth_rel >= 0)) return "overlap_depth_rel: must be >= 0";
  return {};
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
    for (int i = 0; i < options.max_parts; ++i) {
      even.push_back(chosen[static_cast<size_t>(i) * (chosen.size() - 1) /
                            static_cast<size_t>(std::max(options.max_parts - 1, 1))]);
    }
    chosen = even;
  }

  std::vector<PartView> views;
  for (int k : chosen) {
    const WalkKeyframe& keyframe = keyframes[static_cast<size_t>(k)];
    const cv::Mat image = image_of(k);
    if (image.empty()) continue;
    cv::Mat gray;
    cv::cvtColor(image, gray, cv::COLOR_BGR2GRAY);
    std::vector<Eigen::Vector3d> points_in_cam;
    for (int id : points_of(k)) {
      points_in_cam.push_back(keyframe.cam_from_segment *
                              points[static_cast<size_t>(id)].position_in_segment);
    }
    WalkMeshPart part;
    part.keyframe = k;
    PartView view{keyframe.cam_from_segment, std::nullopt};
    if (options.dense) {
      // The stereo partner: the keyframe before it in the segment (after it for the first).
      const auto it = std::find(members.begin(), members.end(), k);
      const int partner =
          it == members.begin() ? (members.size() > 1 ? members[1] : -1) : *(it - 1);
      const cv::Mat partner_image = partner >= 0 ? image_of(partner) : cv::Mat();
      if (!partner_image.empty()) {
        cv::Mat partner_gray;
        cv::cvtColor(partner_image, partner_gray, cv::COLOR_BGR2GRAY);
        const Eigen::Isometry3d partner_from_cam =
            keyframes[static_cast<size_t>(partner)].cam_from_segment *
            keyframe.cam_from_segment.inverse();
        DenseDepth depth =
            ComputeDenseDepth(gray, partner_gray, K, partner_from_cam.linear(),
                              partner_from_cam.translation(), points_in_cam, options.depth);
        if (depth.success) {
          part.mesh = BuildDenseMesh(depth, K, image.cols, image.rows, options.dense_mesh);
          part.dense = !part.mesh.triangles.empty();
          if (part.dense) view.depth = std::move(depth);
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
    // Drop what an earlier part already holds.
    if (options.overlap_parts > 0 && !views.empty()) {
      std::vector<char> keep(part.mesh.triangles.size(), 1);
      const size_t first = views.size() > static_cast<size_t>(options.overlap_parts)
                               ? views.size() - static_cast<size_t>(options.overlap_parts)
                               : 0;
      for (size_t t = 0; t < part.mesh.triangles.size(); ++t) {
        const Eigen::Vector3i& tri = part.mesh.triangles[t];
        const Eigen::Vector3d centroid = ((part.mesh.vertices[static_cast<size_t>(tri[0])] +
                                           part.mesh.vertices[static_cast<size_t>(tri[1])] +
                                           part.mesh.vertices[static_cast<size_t>(tri[2])]) /
                                          3.0f)
                                             .cast<double>();
        for (size_t q = first; q < views.size(); ++q) {
          if (SeenBy(views[q], K, image.cols, image.rows, centroid, options.overlap_depth_rel)) {
            keep[t] = 0;
            ++part.dropped_overlap;
            break;
          }
        }
      }
      if (part.dropped_overlap > 0) KeepTriangles(keep, &part.mesh);
    }
    views.push_back(std::move(view));
    s.dropped_overlap += part.dropped_overlap;
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
