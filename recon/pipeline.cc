#include "recon/pipeline.h"

#include <Eigen/LU>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <map>
#include <opencv2/imgproc.hpp>

#include "base/clock.h"

namespace mm {

namespace {

using Clock = std::chrono::steady_clock;

// Appends the tracks that are not a SIFT match already (no matched A pixel within
// `duplicate_px`; a uniform grid of that cell size finds the neighbours).
void AppendTracks(std::span<const TrackCorrespondence> tracks, double duplicate_px,
                  std::vector<Eigen::Vector2d>* pixels_a, std::vector<Eigen::Vector2d>* pixels_b) {
  if (tracks.empty()) return;
  const double cell = std::max(duplicate_px, 1.0);
  auto key = [cell](const Eigen::Vector2d& p) {
    return std::pair<int64_t, int64_t>(static_cast<int64_t>(std::floor(p.x() / cell)),
                                       static_cast<int64_t>(std::floor(p.y() / cell)));
  };
  std::map<std::pair<int64_t, int64_t>, std::vector<Eigen::Vector2d>> grid;
  for (const Eigen::Vector2d& p : *pixels_a) grid[key(p)].push_back(p);
  const double limit_sq = duplicate_px * duplicate_px;
  auto near_a_match = [&](const Eigen::Vector2d& q) {
    const auto [cx, cy] = key(q);
    for (int64_t dx = -1; dx <= 1; ++dx) {
      for (int64_t dy = -1; dy <= 1; ++dy) {
        const auto it = grid.find({cx + dx, cy + dy});
        if (it == grid.end()) continue;
        for (const Eigen::Vector2d& p : it->second) {
          if ((p - q).squaredNorm() <= limit_sq) return true;
        }
      }
    }
    return false;
  };
  for (const TrackCorrespondence& track : tracks) {
    if (near_a_match(track.pixel_a)) continue;
    pixels_a->push_back(track.pixel_a);
    pixels_b->push_back(track.pixel_b);
  }
}

}  // namespace

cv::Mat ToGray(const cv::Mat& image) {
  if (image.type() == CV_8UC1) return image;
  cv::Mat gray;
  cv::cvtColor(image, gray, cv::COLOR_BGR2GRAY);
  return gray;
}

std::optional<MeshMode> ParseMeshMode(std::string_view name) {
  if (name == "dense") return MeshMode::kDense;
  if (name == "sparse") return MeshMode::kSparse;
  return std::nullopt;
}

const char* MeshModeName(MeshMode mode) { return mode == MeshMode::kDense ? "dense" : "sparse"; }

std::string PairOptions::Check() const {
  for (const std::string& problem :
       {sift.Check(), match.Check(), two_view.Check(), refinement.Check(), mesh.Check(),
        dense.Check(), dense_mesh.Check(), view_pose.Check()}) {
    if (!problem.empty()) return problem;
  }
  if (!(track_duplicate_px >= 0)) return "track_duplicate_px: must be >= 0";
  if (max_intermediate_views < 0 || max_intermediate_views > 8) {
    return "max_intermediate_views: must be in [0, 8]";
  }
  if (max_views_before_a < 0 || max_views_before_a > 8) {
    return "max_views_before_a: must be in [0, 8]";
  }
  if (!(intermediate_baseline_share[0] >= 0 &&
        intermediate_baseline_share[1] >= intermediate_baseline_share[0])) {
    return "intermediate_baseline_share: must be 0 <= low <= high";
  }
  return {};
}

Features ExtractKeyframeFeatures(const cv::Mat& image, const PairOptions& options) {
  if (image.empty()) return {};
  return ExtractSift(ToGray(image), options.sift);
}

SourceView MatchSourceView(const Features& features_a, const cv::Mat& image,
                           const PairOptions& options) {
  return MatchSourceView(features_a, image, ExtractKeyframeFeatures(image, options), options);
}

SourceView MatchSourceView(const Features& features_a, const cv::Mat& image,
                           const Features& features, const PairOptions& options) {
  SourceView view{image, {}};
  if (image.empty()) return view;
  for (const Match& m :
       MatchDescriptors(features_a.descriptors, features.descriptors, options.match)) {
    const cv::Point2f& pa = features_a.keypoints[static_cast<size_t>(m.index_a)].pt;
    const cv::Point2f& pv = features.keypoints[static_cast<size_t>(m.index_b)].pt;
    view.correspondences.push_back({Eigen::Vector2d(pa.x, pa.y), Eigen::Vector2d(pv.x, pv.y)});
  }
  return view;
}

namespace {

// Every 4th pixel of the shrunk depth map each way (at 640x480: up to 80x60 points).
constexpr int kDenseSampleStride = 4;

// The dense depth's pixels, every kDenseSampleStride-th, lifted into A's frame.
std::vector<Eigen::Vector3d> DenseDepthPoints(const DenseDepth& depth) {
  std::vector<Eigen::Vector3d> points;
  if (!depth.success) return points;
  const Eigen::Matrix3d K_inv = depth.K.inverse();
  for (int v = 0; v < depth.inverse_depth.rows; v += kDenseSampleStride) {
    const auto* row = depth.inverse_depth.ptr<float>(v);
    for (int u = 0; u < depth.inverse_depth.cols; u += kDenseSampleStride) {
      if (!(row[u] > 0)) continue;
      points.push_back(K_inv * Eigen::Vector3d(u, v, 1.0) / static_cast<double>(row[u]));
    }
  }
  return points;
}

}  // namespace

void ScalePairReconstruction(double metres_per_unit, PairReconstruction* pair) {
  TwoViewResult& g = pair->geometry;
  g.translation *= metres_per_unit;
  for (Eigen::Vector3d& p : g.points_in_cam_a) p *= metres_per_unit;
  for (Eigen::Vector3d& p : pair->dense_points_in_a) p *= metres_per_unit;
  const auto f = static_cast<float>(metres_per_unit);
  for (Eigen::Vector3f& v : pair->mesh.vertices) v *= f;
  pair->mesh_summary.voxel_size *= metres_per_unit;
}

PairReconstruction ReconstructPair(const cv::Mat& image_a, const cv::Mat& image_b,
                                   const BouguetCamera& camera, const PairOptions& options,
                                   std::span<const SourceView> between) {
  if (image_a.empty() || image_b.empty() || image_a.size() != image_b.size()) {
    PairReconstruction out;
    out.failure_reason = "keyframes are empty or of different sizes";
    return out;
  }
  const auto start = Clock::now();
  const Features features_a = ExtractKeyframeFeatures(image_a, options);
  const double features_a_s = SecondsSince(start);
  PairReconstruction out =
      ReconstructPair(features_a, image_a, image_b, camera, options, {}, between);
  out.times.features_a_s = features_a_s;
  return out;
}

ChosenSourceViews ChooseSourceViews(std::span<const SourceView> between,
                                    const TwoViewResult& geometry,
                                    std::span<const Eigen::Vector2d> point_pixels_a,
                                    const Eigen::Matrix3d& K, cv::Size image_size,
                                    const PairOptions& options) {
  ChosenSourceViews out;
  struct Posed {
    const SourceView* view;
    ViewPose pose;
    bool before_a;
  };
  std::vector<Posed> posed;
  const Eigen::Vector3d centre_b = -geometry.rotation.transpose() * geometry.translation;
  for (const SourceView& view : between) {
    if (view.image.size() != image_size) {
      out.left_out.emplace_back("source view of another size");
      continue;
    }
    std::vector<Eigen::Vector2d> in_a, in_view;
    in_a.reserve(view.correspondences.size());
    in_view.reserve(view.correspondences.size());
    for (const TrackCorrespondence& c : view.correspondences) {
      in_a.push_back(c.pixel_a);
      in_view.push_back(c.pixel_b);
    }
    ViewPose pose = EstimateViewPose(geometry.points_in_cam_a, point_pixels_a, in_a, in_view, K,
                                     options.view_pose);
    if (!pose.success) {
      out.left_out.push_back(std::move(pose.failure_reason));
      continue;
    }
    // Near A it adds no depth resolution, far from it no other view of the scene.
    const double share = pose.translation_from_a.norm() / geometry.translation.norm();
    if (share < options.intermediate_baseline_share[0] ||
        share > options.intermediate_baseline_share[1]) {
      out.left_out.push_back("view at " +
                             std::to_string(static_cast<int>(std::lround(100 * share))) +
                             " % of B's distance from A");
      continue;
    }
    const Eigen::Vector3d centre = -pose.rotation_from_a.transpose() * pose.translation_from_a;
    const bool before_a = centre.dot(centre_b) < 0;
    posed.push_back({&view, std::move(pose), before_a});
  }
  const double half_baseline = 0.5 * geometry.translation.norm();
  auto off_halfway = [half_baseline](const Posed& v) {
    return std::abs(v.pose.translation_from_a.norm() - half_baseline);
  };
  std::stable_sort(posed.begin(), posed.end(),
                   [&](const Posed& l, const Posed& r) { return off_halfway(l) < off_halfway(r); });
  int taken_between = 0;
  for (const Posed& v : posed) {
    const int limit = v.before_a ? options.max_views_before_a : options.max_intermediate_views;
    int& taken = v.before_a ? out.before_a : taken_between;
    if (taken >= limit) {
      out.left_out.emplace_back("a view nearer halfway was taken");
      continue;
    }
    ++taken;
    out.views.push_back({ToGray(v.view->image), v.pose.rotation_from_a, v.pose.translation_from_a});
  }
  return out;
}

PairReconstruction ReconstructPair(const Features& features_a, const cv::Mat& image_a,
                                   const cv::Mat& image_b, const BouguetCamera& camera,
                                   const PairOptions& options,
                                   std::span<const TrackCorrespondence> tracks,
                                   std::span<const SourceView> between) {
  PairReconstruction out;
  if (image_a.empty() || image_b.empty() || image_a.size() != image_b.size()) {
    out.failure_reason = "keyframes are empty or of different sizes";
    return out;
  }
  auto start = Clock::now();
  const cv::Mat gray_b = ToGray(image_b);
  const Features features_b = ExtractSift(gray_b, options.sift);
  if (options.release_sift_workspace_after_b) ReleaseSiftWorkspace();
  out.times.features_b_s = SecondsSince(start);
  out.features_a = static_cast<int>(features_a.keypoints.size());
  out.features_b = static_cast<int>(features_b.keypoints.size());

  start = Clock::now();
  const std::vector<Match> matches =
      MatchDescriptors(features_a.descriptors, features_b.descriptors, options.match);
  out.times.matching_s = SecondsSince(start);
  out.matches = static_cast<int>(matches.size());

  start = Clock::now();
  std::vector<Eigen::Vector2d> pixels_a, pixels_b;
  pixels_a.reserve(matches.size());
  pixels_b.reserve(matches.size());
  for (const Match& m : matches) {
    const cv::Point2f& pa = features_a.keypoints[static_cast<size_t>(m.index_a)].pt;
    const cv::Point2f& pb = features_b.keypoints[static_cast<size_t>(m.index_b)].pt;
    pixels_a.emplace_back(pa.x, pa.y);
    pixels_b.emplace_back(pb.x, pb.y);
  }
  out.tracks = static_cast<int>(tracks.size());
  AppendTracks(tracks, options.track_duplicate_px, &pixels_a, &pixels_b);
  out.tracks_used = static_cast<int>(pixels_a.size()) - out.matches;
  out.geometry = EstimateTwoView(pixels_a, pixels_b, camera.K(), options.two_view);
  for (int index : out.geometry.inliers) out.track_inliers += index >= out.matches ? 1 : 0;
  if (!out.geometry.success) {
    out.times.geometry_s = SecondsSince(start);
    out.failure_reason = out.geometry.failure_reason;
    return out;
  }
  for (int index : out.geometry.point_correspondence) {
    out.point_pixels_a.push_back(pixels_a[static_cast<size_t>(index)]);
    out.point_pixels_b.push_back(pixels_b[static_cast<size_t>(index)]);
  }
  const cv::Mat gray_a = ToGray(image_a);
  out.refinement = RefinePoints(gray_a, gray_b, camera.K(), options.two_view, options.refinement,
                                out.point_pixels_a, &out.point_pixels_b, &out.geometry);
  out.times.geometry_s = SecondsSince(start);

  if (options.mesh_mode == MeshMode::kDense) {
    start = Clock::now();
    ChosenSourceViews chosen = ChooseSourceViews(between, out.geometry, out.point_pixels_a,
                                                 camera.K(), image_a.size(), options);
    out.intermediate_views = static_cast<int>(between.size());
    out.intermediate_views_used = static_cast<int>(chosen.views.size());
    out.views_before_a_used = chosen.before_a;
    out.intermediate_failures = std::move(chosen.left_out);
    const std::vector<DenseView>& views = chosen.views;
    const DenseDepth depth = ComputeDenseDepth(gray_a, gray_b, camera.K(), out.geometry.rotation,
                                               out.geometry.translation,
                                               out.geometry.points_in_cam_a, options.dense, views);
    out.times.dense_s = SecondsSince(start);
    out.dense_valid_fraction = depth.valid_fraction;
    out.dense_planes = depth.planes;
    out.dense_points_in_a = DenseDepthPoints(depth);
    start = Clock::now();
    if (depth.success) {
      out.mesh = BuildDenseMesh(depth, camera.K(), image_a.cols, image_a.rows, options.dense_mesh,
                                &out.dense_mesh_summary);
      if (out.mesh.triangles.empty()) out.dense_failure_reason = "dense mesh has no triangles";
    } else {
      out.dense_failure_reason = depth.failure_reason;
    }
    if (out.dense_failure_reason.empty()) out.mesh_mode = MeshMode::kDense;
    out.times.meshing_s = SecondsSince(start);
  }
  start = Clock::now();
  if (out.mesh_mode == MeshMode::kSparse) {
    out.mesh = BuildDelaunayMesh(out.geometry.points_in_cam_a, out.point_pixels_a, image_a.cols,
                                 image_a.rows, options.mesh, &out.mesh_summary);
  }
  if (image_a.type() == CV_8UC3) ColorVerticesFromTexture(image_a, &out.mesh);
  out.times.meshing_s += SecondsSince(start);
  if (out.mesh.triangles.empty()) {
    out.failure_reason = "mesh has no triangles";
    return out;
  }
  out.success = true;
  return out;
}

}  // namespace mm
