#include "map/walk_refine.h"

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <map>
#include <numeric>
#include <tuple>
#include <utility>

#include "base/clock.h"
#include "base/stats.h"
#include "map/walk_map.h"

namespace mm {

std::string TrackRefineOptions::Check() const {
  if (std::string e = sift.Check(); !e.empty()) return "sift: " + e;
  if (std::string e = match.Check(); !e.empty()) return "match: " + e;
  if (std::string e = verify.Check(); !e.empty()) return "verify: " + e;
  if (std::string e = bundle.Check(); !e.empty()) return "bundle: " + e;
  if (!(max_axis_angle_deg > 0 && max_axis_angle_deg <= 180)) {
    return "max_axis_angle_deg must be in (0, 180]";
  }
  if (min_pair_inliers < 8) return "min_pair_inliers must be at least 8";
  if (!(min_angle_deg >= 0)) return "min_angle_deg must be >= 0";
  if (triangulation_tries < 1) return "triangulation_tries must be at least 1";
  if (max_track_length < 2) return "max_track_length must be at least 2";
  if (!(max_reprojection_px > 0) || !(final_reprojection_px > 0)) {
    return "reprojection thresholds must be > 0";
  }
  if (max_keyframes < 3) return "max_keyframes must be at least 3";
  return {};
}

namespace {

int Root(std::vector<int>& parent, int x) {
  while (parent[static_cast<size_t>(x)] != x) {
    parent[static_cast<size_t>(x)] = parent[static_cast<size_t>(parent[static_cast<size_t>(x)])];
    x = parent[static_cast<size_t>(x)];
  }
  return x;
}

void Join(std::vector<int>& parent, int x, int y) {
  x = Root(parent, x);
  y = Root(parent, y);
  if (x != y) parent[static_cast<size_t>(std::max(x, y))] = std::min(x, y);
}

double ReprojectionPx(const Eigen::Matrix3d& k, const Eigen::Isometry3d& cam_from_world,
                      const Eigen::Vector3d& point_in_world, const Eigen::Vector2d& pixel) {
  const Eigen::Vector3d x = cam_from_world * point_in_world;
  if (x.z() <= 0) return std::numeric_limits<double>::infinity();
  return ((k * x).hnormalized() - pixel).norm();
}

// Whether the point keyframe a looks at (depth_a along its axis) is in b's image.
bool SeesLookAt(const Eigen::Matrix3d& k, const Eigen::Isometry3d& a_from_world, double depth_a,
                const Eigen::Isometry3d& b_from_world, const cv::Size& size_b) {
  if (!(depth_a > 0)) return false;
  const Eigen::Vector3d in_b =
      b_from_world * (a_from_world.inverse() * Eigen::Vector3d(0, 0, depth_a));
  if (in_b.z() <= 0) return false;
  const Eigen::Vector2d pixel = (k * in_b).hnormalized();
  return pixel.x() >= 0 && pixel.y() >= 0 && pixel.x() < size_b.width && pixel.y() < size_b.height;
}

// The point of a track from the widest of its pairs (up to options.triangulation_tries) that
// the most of its keyframes agree with, one observation per keyframe (the nearest); false when
// no pair gives two.
bool TriangulateTrack(const Eigen::Matrix3d& k,
                      const std::vector<Eigen::Isometry3d>& cam_from_world, const Track& track,
                      const TrackRefineOptions& options, Eigen::Vector3d* point_in_world,
                      Track* inlying) {
  const Eigen::Matrix3d k_inv = k.inverse();
  std::vector<Eigen::Vector3d> normalized(track.size()), ray_in_world(track.size());
  for (size_t i = 0; i < track.size(); ++i) {
    normalized[i] = k_inv * track[i].pixel.homogeneous();
    ray_in_world[i] = cam_from_world[static_cast<size_t>(track[i].keyframe)].linear().transpose() *
                      normalized[i].normalized();
  }
  std::vector<std::tuple<double, size_t, size_t>> pairs;  // (angle, i, j), widest first
  for (size_t i = 0; i < track.size(); ++i) {
    for (size_t j = i + 1; j < track.size(); ++j) {
      if (track[i].keyframe == track[j].keyframe) continue;
      const double angle_deg =
          std::acos(std::clamp(ray_in_world[i].dot(ray_in_world[j]), -1.0, 1.0)) * 180.0 / M_PI;
      if (angle_deg >= options.min_angle_deg) pairs.emplace_back(angle_deg, i, j);
    }
  }
  std::sort(pairs.begin(), pairs.end(), std::greater<>());
  pairs.resize(std::min(pairs.size(), static_cast<size_t>(options.triangulation_tries)));
  inlying->clear();
  for (const auto& [angle_deg, i, j] : pairs) {
    const Eigen::Isometry3d& a_from_world = cam_from_world[static_cast<size_t>(track[i].keyframe)];
    const Eigen::Isometry3d b_from_a =
        cam_from_world[static_cast<size_t>(track[j].keyframe)] * a_from_world.inverse();
    RelativePose pose;
    pose.rotation = b_from_a.linear();
    pose.translation = b_from_a.translation();
    const Eigen::Vector2d xa = normalized[i].hnormalized();
    const Eigen::Vector2d xb = normalized[j].hnormalized();
    const Eigen::Vector3d p_a = RefineTriangulation(TriangulateLinear(xa, xb, pose), xa, xb, pose);
    if (p_a.z() <= 0 || (b_from_a * p_a).z() <= 0) continue;
    if (TriangulationAngleDeg(p_a, pose) < options.min_angle_deg) continue;
    const Eigen::Vector3d candidate = a_from_world.inverse() * p_a;
    std::map<int, std::pair<double, size_t>> nearest;  // keyframe -> (error px, index in track)
    for (size_t t = 0; t < track.size(); ++t) {
      const TrackObservation& o = track[t];
      const double e =
          ReprojectionPx(k, cam_from_world[static_cast<size_t>(o.keyframe)], candidate, o.pixel);
      if (e > options.max_reprojection_px) continue;
      const auto it = nearest.find(o.keyframe);
      if (it == nearest.end() || e < it->second.first) nearest[o.keyframe] = {e, t};
    }
    if (nearest.size() < 2 || nearest.size() <= inlying->size()) continue;
    inlying->clear();
    for (const auto& [keyframe, error_and_index] : nearest) {
      inlying->push_back(track[error_and_index.second]);
    }
    *point_in_world = candidate;
  }
  return inlying->size() >= 2;
}

}  // namespace

std::vector<Track> BuildTracks(const Eigen::Matrix3d& k, const std::vector<cv::Mat>& grays,
                               const std::vector<Eigen::Isometry3d>& cam_from_world,
                               const std::vector<double>& scene_depth,
                               const TrackRefineOptions& options, TrackRefineSummary* summary) {
  const size_t n = grays.size();
  std::vector<Track> tracks;
  if (cam_from_world.size() != n || scene_depth.size() != n) return tracks;
  // Every keypoint of every keyframe is a node, offset[i] + its index. Descriptors as 8-bit
  // (the matcher rounds them so: the same matches, a quarter of the memory).
  std::vector<cv::Mat> descriptors(n);
  std::vector<std::vector<Eigen::Vector2d>> pixels(n);
  std::vector<int> offset(n + 1, 0);
  for (size_t i = 0; i < n; ++i) {
    const Features features = ExtractSift(grays[i], options.sift);
    features.descriptors.convertTo(descriptors[i], CV_8U);
    for (const cv::KeyPoint& kp : features.keypoints) pixels[i].emplace_back(kp.pt.x, kp.pt.y);
    offset[i + 1] = offset[i] + static_cast<int>(pixels[i].size());
  }
  std::vector<int> parent(static_cast<size_t>(offset[n]));
  std::iota(parent.begin(), parent.end(), 0);
  const double min_axis_cos = std::cos(options.max_axis_angle_deg * M_PI / 180.0);
  for (size_t a = 0; a < n; ++a) {
    for (size_t b = a + 1; b < n; ++b) {
      const double axis_cos =
          cam_from_world[a].linear().row(2).dot(cam_from_world[b].linear().row(2));
      const bool overlap =
          axis_cos >= min_axis_cos &&
          (SeesLookAt(k, cam_from_world[a], scene_depth[a], cam_from_world[b], grays[b].size()) ||
           SeesLookAt(k, cam_from_world[b], scene_depth[b], cam_from_world[a], grays[a].size()));
      if (b != a + 1 && !overlap) continue;
      ++summary->pairs;
      const std::vector<Match> matches =
          MatchDescriptors(descriptors[a], descriptors[b], options.match);
      if (static_cast<int>(matches.size()) < options.min_pair_inliers) continue;
      std::vector<Eigen::Vector2d> pixels_a, pixels_b;
      for (const Match& m : matches) {
        pixels_a.push_back(pixels[a][static_cast<size_t>(m.index_a)]);
        pixels_b.push_back(pixels[b][static_cast<size_t>(m.index_b)]);
      }
      RansacOptions verify = options.verify;
      verify.seed = static_cast<unsigned>(options.verify.seed + a * n + b);
      const RansacResult f = RansacFundamental(pixels_a, pixels_b, verify);
      if (!f.success || static_cast<int>(f.inliers.size()) < options.min_pair_inliers) continue;
      ++summary->verified_pairs;
      for (int i : f.inliers) {
        const Match& m = matches[static_cast<size_t>(i)];
        Join(parent, offset[a] + m.index_a, offset[b] + m.index_b);
      }
    }
  }
  std::map<int, Track> by_root;
  for (size_t view = 0; view < n; ++view) {
    for (size_t i = 0; i < pixels[view].size(); ++i) {
      by_root[Root(parent, offset[view] + static_cast<int>(i))].push_back(
          {static_cast<int>(view), pixels[view][i]});
    }
  }
  for (auto& [root, track] : by_root) {
    if (track.size() >= 2) tracks.push_back(std::move(track));
  }
  summary->tracks = static_cast<int>(tracks.size());
  return tracks;
}

TrackRefineResult RefinePosesWithTracks(const Eigen::Matrix3d& k, const std::vector<Track>& tracks,
                                        const std::vector<Eigen::Isometry3d>& cam_from_world,
                                        const TrackRefineOptions& options,
                                        const LocalBundleProblem* kept) {
  TrackRefineResult result;
  result.cam_from_world = cam_from_world;
  TrackRefineSummary& s = result.summary;
  s.keyframes = static_cast<int>(cam_from_world.size());
  s.tracks = static_cast<int>(tracks.size());
  if (cam_from_world.size() < 3) return result;
  LocalBundleProblem problem;
  problem.k = k;
  problem.cam_from_world = cam_from_world;
  problem.pose_fixed.assign(cam_from_world.size(), false);
  problem.pose_fixed[0] = problem.pose_fixed[1] = true;
  // The kept points first: indices [0, kept_points) of the problem's points.
  if (kept) {
    problem.points_in_world = kept->points_in_world;
    problem.observations = kept->observations;
  }
  const size_t kept_points = problem.points_in_world.size();
  const size_t kept_observations = problem.observations.size();
  // Each track triangulated under the problem's poses, its observations within threshold_px.
  const auto add_tracks = [&](double threshold_px) {
    TrackRefineOptions within = options;
    within.max_reprojection_px = threshold_px;
    Track inlying;
    for (const Track& track : tracks) {
      if (static_cast<int>(track.size()) > options.max_track_length) continue;
      Eigen::Vector3d point_in_world;
      if (!TriangulateTrack(k, problem.cam_from_world, track, within, &point_in_world, &inlying)) {
        continue;
      }
      const int id = static_cast<int>(problem.points_in_world.size());
      problem.points_in_world.push_back(point_in_world);
      for (const TrackObservation& o : inlying) {
        problem.observations.push_back({o.keyframe, id, o.pixel});
      }
    }
  };
  // First under the walk's poses with a wide threshold; then, the poses adjusted, every track
  // again with the final one (observations the drift had put out of reach come back, as in
  // COLMAP's retriangulation), adjusted once more.
  add_tracks(options.max_reprojection_px);
  AdjustLocalBundle(options.bundle, &problem);
  problem.points_in_world.resize(kept_points);
  problem.observations.resize(kept_observations);
  add_tracks(options.final_reprojection_px);
  s.points = static_cast<int>(problem.points_in_world.size() - kept_points);
  s.observations = static_cast<int>(problem.observations.size() - kept_observations);
  s.bundle = AdjustLocalBundle(options.bundle, &problem);
  s.ran = s.bundle.ran;
  if (s.ran) {
    result.cam_from_world = problem.cam_from_world;
    result.kept_points_in_world.assign(
        problem.points_in_world.begin(),
        problem.points_in_world.begin() + static_cast<long>(kept_points));
  }
  return result;
}

TrackRefineSummary RefineSegment(WalkMap* map, int segment, const Eigen::Matrix3d& k,
                                 const KeyframeImageFn& image_of,
                                 const TrackRefineOptions& options) {
  const double cpu_start = ThreadCpuSeconds();
  std::vector<int> keyframes;
  for (size_t i = 0; i < map->keyframes().size(); ++i) {
    const WalkKeyframe& keyframe = map->keyframes()[i];
    if (keyframe.registered && keyframe.segment == segment)
      keyframes.push_back(static_cast<int>(i));
  }
  TrackRefineSummary skipped;
  skipped.keyframes = static_cast<int>(keyframes.size());
  if (static_cast<int>(keyframes.size()) > options.max_keyframes) {
    skipped.skipped = std::to_string(keyframes.size()) + " keyframes (max_keyframes " +
                      std::to_string(options.max_keyframes) + ")";
    return skipped;
  }
  if (keyframes.size() < 3) {
    skipped.skipped = "fewer than 3 keyframes";
    return skipped;
  }
  // The segment's own points (seen twice or more) and observations, kept in the adjustment.
  std::vector<int> point_ids;
  const LocalBundleProblem own = map->BundleProblemOf(keyframes, segment, 2, &point_ids);
  const std::vector<Eigen::Isometry3d>& cam_from_segment = own.cam_from_world;
  std::vector<cv::Mat> grays;
  std::vector<double> scene_depth;  // The median depth of each keyframe's points.
  for (int i : keyframes) {
    const WalkKeyframe& keyframe = map->keyframes()[static_cast<size_t>(i)];
    cv::Mat image = image_of(i);
    if (image.empty()) {
      skipped.skipped = "no image of keyframe " + std::to_string(i);
      return skipped;
    }
    if (image.channels() == 3) cv::cvtColor(image, image, cv::COLOR_BGR2GRAY);
    std::vector<double> depths;
    for (int point : keyframe.point_of_keypoint) {
      if (point < 0) continue;
      const WalkPoint& p = map->points()[static_cast<size_t>(point)];
      if (p.valid) depths.push_back((keyframe.cam_from_segment * p.position_in_segment).z());
    }
    grays.push_back(std::move(image));
    scene_depth.push_back(MedianOf(std::move(depths)));
  }
  TrackRefineSummary built;
  const std::vector<Track> tracks =
      BuildTracks(k, grays, cam_from_segment, scene_depth, options, &built);
  grays.clear();
  TrackRefineResult refined = RefinePosesWithTracks(k, tracks, cam_from_segment, options, &own);
  refined.summary.pairs = built.pairs;
  refined.summary.verified_pairs = built.verified_pairs;
  if (refined.summary.ran) {
    std::map<int, Eigen::Isometry3d> poses;
    for (size_t j = 0; j < keyframes.size(); ++j) poses[keyframes[j]] = refined.cam_from_world[j];
    std::map<int, Eigen::Vector3d> positions;
    for (size_t j = 0; j < point_ids.size(); ++j) {
      positions[point_ids[j]] = refined.kept_points_in_world[j];
    }
    map->MoveKeyframes(poses, positions);
  }
  refined.summary.cpu_s = ThreadCpuSeconds() - cpu_start;
  return refined.summary;
}

}  // namespace mm
