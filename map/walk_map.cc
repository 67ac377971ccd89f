#include "map/walk_map.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <map>

#include "recon/epipolar.h"
#include "recon/view_pose.h"

namespace mm {
namespace {

using Clock = std::chrono::steady_clock;

Eigen::Vector2d Project(const Eigen::Matrix3d& k, const Eigen::Vector3d& x_cam) {
  const Eigen::Vector3d p = k * x_cam;
  return p.head<2>() / p.z();
}

double SecondsSince(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

}  // namespace

std::string WalkOptions::Check() const {
  if (std::string p = sift.Check(); !p.empty()) return "sift." + p;
  if (std::string p = match.Check(); !p.empty()) return "match." + p;
  if (std::string p = two_view.Check(); !p.empty()) return "two_view." + p;
  if (std::string p = bundle.Check(); !p.empty()) return "bundle." + p;
  if (match_keyframes < 1) return "match_keyframes: must be >= 1";
  if (!(pnp_reprojection_px > 0)) return "pnp_reprojection_px: must be > 0";
  if (pnp_iterations < 1) return "pnp_iterations: must be >= 1";
  if (min_pnp_inliers < 6) return "min_pnp_inliers: must be >= 6";
  if (!(max_reprojection_px > 0)) return "max_reprojection_px: must be > 0";
  if (!(min_triangulation_angle_deg >= 0)) return "min_triangulation_angle_deg: must be >= 0";
  if (!(search_radius_px >= 0)) return "search_radius_px: must be >= 0";
  if (window < 3) return "window: must be >= 3 (two keyframes are fixed)";
  return {};
}

WalkMap::WalkMap(const Eigen::Matrix3d& K, const WalkOptions& options) : K_(K), options_(options) {}

Eigen::Vector2d WalkMap::Pixel(int keyframe, int keypoint) const {
  return keyframes_[static_cast<size_t>(keyframe)]
      .keypoint_pixels[static_cast<size_t>(keypoint)]
      .cast<double>();
}

std::vector<int> WalkMap::SegmentKeyframes() const {
  std::vector<int> out;
  for (int i = segment_start_; i < static_cast<int>(keyframes_.size()); ++i) {
    if (keyframes_[static_cast<size_t>(i)].registered) out.push_back(i);
  }
  return out;
}

void WalkMap::StartSegment(int keyframe) {
  if (keyframe > 0) ++segment_;
  segment_start_ = keyframe;
  WalkKeyframe& k = keyframes_[static_cast<size_t>(keyframe)];
  k.segment = segment_;
  k.registered = true;
  k.cam_from_segment = Eigen::Isometry3d::Identity();
}

WalkKeyframeSummary WalkMap::AddKeyframe(const cv::Mat& gray, double timestamp_s) {
  const auto start = Clock::now();
  WalkKeyframeSummary summary;
  summary.index = static_cast<int>(keyframes_.size());
  WalkKeyframe keyframe;
  keyframe.timestamp_s = timestamp_s;
  keyframe.features = ExtractSift(gray, options_.sift);
  summary.sift_s = SecondsSince(start);
  keyframe.point_of_keypoint.assign(keyframe.features.keypoints.size(), -1);
  keyframe.keypoint_pixels.reserve(keyframe.features.keypoints.size());
  for (const cv::KeyPoint& kp : keyframe.features.keypoints) {
    keyframe.keypoint_pixels.emplace_back(kp.pt.x, kp.pt.y);
  }
  keyframe.segment = segment_;
  keyframes_.push_back(std::move(keyframe));
  const int index = summary.index;

  const std::vector<int> segment = SegmentKeyframes();
  bool registered = false;
  if (segment.empty()) {
    StartSegment(index);
    registered = true;
  } else if (segment.size() == 1) {
    registered = Initialize(index, &summary);
    if (!registered) {
      // The segment's lone keyframe and this one do not make a pair: start again from here
      // (the lone keyframe stays a segment of one).
      StartSegment(index);
    }
  } else {
    registered = Register(index, &summary);
    if (registered) {
      const auto bundle_start = Clock::now();
      AdjustWindow(&summary);
      summary.bundle_s = SecondsSince(bundle_start);
    } else {
      StartSegment(index);
    }
  }
  summary.registered = keyframes_.back().registered;
  summary.segment = keyframes_.back().segment;
  // Descriptors are read only for the newest keyframes (matching) and the window (the
  // search by projection compares with a point's newest observation, inside the window):
  // older ones are released, which bounds a long walk's memory (their pixels stay for the BA).
  const int keep = std::max(options_.window, options_.match_keyframes) + 1;
  if (index >= keep) keyframes_[static_cast<size_t>(index - keep)].features = Features{};
  summary.time_s = SecondsSince(start);
  summary.pose_s = summary.time_s - summary.sift_s - summary.matching_s - summary.bundle_s;
  return summary;
}

bool WalkMap::Initialize(int keyframe, WalkKeyframeSummary* summary) {
  const int first = SegmentKeyframes().front();
  WalkKeyframe& a = keyframes_[static_cast<size_t>(first)];
  WalkKeyframe& b = keyframes_[static_cast<size_t>(keyframe)];
  const auto matching_start = Clock::now();
  const std::vector<Match> matches =
      MatchDescriptors(a.features.descriptors, b.features.descriptors, options_.match);
  summary->matching_s = SecondsSince(matching_start);
  summary->matches = static_cast<int>(matches.size());
  std::vector<Eigen::Vector2d> pixels_a, pixels_b;
  for (const Match& m : matches) {
    pixels_a.push_back(Pixel(first, m.index_a));
    pixels_b.push_back(Pixel(keyframe, m.index_b));
  }
  TwoViewOptions two_view = options_.two_view;
  two_view.seed = options_.seed + static_cast<unsigned>(keyframe);
  const TwoViewResult pair = EstimateTwoView(pixels_a, pixels_b, K_, two_view);
  if (!pair.success) {
    summary->failure = "initialization: " + pair.failure_reason;
    return false;
  }
  // The segment's frame is its first keyframe's (a.cam_from_segment = identity).
  Eigen::Isometry3d b_from_a = Eigen::Isometry3d::Identity();
  b_from_a.linear() = pair.rotation;
  b_from_a.translation() = pair.translation;
  b.cam_from_segment = b_from_a * a.cam_from_segment;
  b.segment = segment_;
  b.registered = true;
  for (size_t i = 0; i < pair.points_in_cam_a.size(); ++i) {
    const Match& m = matches[static_cast<size_t>(pair.point_correspondence[i])];
    WalkPoint point;
    point.segment = segment_;
    point.position_in_segment = a.cam_from_segment.inverse() * pair.points_in_cam_a[i];
    point.observations = {{first, m.index_a}, {keyframe, m.index_b}};
    const int id = static_cast<int>(points_.size());
    points_.push_back(std::move(point));
    a.point_of_keypoint[static_cast<size_t>(m.index_a)] = id;
    b.point_of_keypoint[static_cast<size_t>(m.index_b)] = id;
  }
  summary->new_points = static_cast<int>(pair.points_in_cam_a.size());
  return true;
}

bool WalkMap::Register(int keyframe, WalkKeyframeSummary* summary) {
  std::vector<int> segment = SegmentKeyframes();
  WalkKeyframe& k = keyframes_[static_cast<size_t>(keyframe)];
  // Newest first: a keypoint of the new keyframe takes the map point of its match in the
  // newest keyframe that has one.
  const int count = std::min<int>(options_.match_keyframes, static_cast<int>(segment.size()));
  std::map<int, int> point_of_new_keypoint;
  std::vector<std::vector<Match>> matches_to(static_cast<size_t>(count));
  const auto matching_start = Clock::now();
  for (int j = 0; j < count; ++j) {
    const int other = segment[segment.size() - 1 - static_cast<size_t>(j)];
    matches_to[static_cast<size_t>(j)] =
        MatchDescriptors(keyframes_[static_cast<size_t>(other)].features.descriptors,
                         k.features.descriptors, options_.match);
    summary->matches += static_cast<int>(matches_to[static_cast<size_t>(j)].size());
    for (const Match& m : matches_to[static_cast<size_t>(j)]) {
      const int id =
          keyframes_[static_cast<size_t>(other)].point_of_keypoint[static_cast<size_t>(m.index_a)];
      if (id >= 0 && points_[static_cast<size_t>(id)].valid) {
        point_of_new_keypoint.emplace(m.index_b, id);
      }
    }
  }
  summary->matching_s = SecondsSince(matching_start);
  std::vector<Eigen::Vector3d> object;
  std::vector<Eigen::Vector2d> image;
  std::vector<std::pair<int, int>> correspondence;  // (new keypoint, point)
  for (const auto& [keypoint, id] : point_of_new_keypoint) {
    object.push_back(points_[static_cast<size_t>(id)].position_in_segment);
    image.push_back(Pixel(keyframe, keypoint));
    correspondence.emplace_back(keypoint, id);
  }
  summary->matches_3d = static_cast<int>(object.size());
  if (summary->matches_3d < options_.min_pnp_inliers) {
    summary->failure = "registration: " + std::to_string(summary->matches_3d) +
                       " matches to map points (need " + std::to_string(options_.min_pnp_inliers) +
                       ")";
    return false;
  }
  const PnpRansacPose pose = SolvePnpRansacRefined(object, image, K_,
                                                   {.threshold_px = options_.pnp_reprojection_px,
                                                    .iterations = options_.pnp_iterations,
                                                    .confidence = 0.9999,
                                                    .sqpnp = true});
  summary->pnp_inliers = static_cast<int>(pose.inliers.size());
  if (!pose.found || summary->pnp_inliers < options_.min_pnp_inliers) {
    summary->failure = "registration: " + std::to_string(summary->pnp_inliers) +
                       " PnP inliers of " + std::to_string(summary->matches_3d) + " (need " +
                       std::to_string(options_.min_pnp_inliers) + ")";
    return false;
  }
  k.cam_from_segment.linear() = pose.rotation;
  k.cam_from_segment.translation() = pose.translation;
  k.segment = segment_;
  k.registered = true;
  // Observations of the map points, re-checked under the refined pose.
  for (const auto& [keypoint, id] : correspondence) {
    WalkPoint& point = points_[static_cast<size_t>(id)];
    const Eigen::Vector3d x = k.cam_from_segment * point.position_in_segment;
    if (x.z() <= 0 ||
        (Project(K_, x) - Pixel(keyframe, keypoint)).norm() > options_.pnp_reprojection_px) {
      continue;
    }
    point.observations.push_back({keyframe, keypoint});
    k.point_of_keypoint[static_cast<size_t>(keypoint)] = id;
  }
  summary->projected_matches = SearchByProjection(keyframe);
  // New points from the matches to the newest keyframes that have no point yet.
  for (int j = 0; j < count; ++j) {
    const int other = segment[segment.size() - 1 - static_cast<size_t>(j)];
    summary->new_points += TriangulateWith(keyframe, other, matches_to[static_cast<size_t>(j)]);
  }
  return true;
}

int WalkMap::SearchByProjection(int keyframe) {
  if (options_.search_radius_px <= 0) return 0;
  WalkKeyframe& k = keyframes_[static_cast<size_t>(keyframe)];
  const std::vector<cv::KeyPoint>& keypoints = k.features.keypoints;
  if (keypoints.empty()) return 0;
  // Keypoints without a point, bucketed in cells of the search radius.
  const double cell = std::max(options_.search_radius_px, 1.0);
  std::multimap<std::pair<int, int>, int> grid;
  for (size_t i = 0; i < keypoints.size(); ++i) {
    if (k.point_of_keypoint[i] >= 0) continue;
    grid.emplace(std::make_pair(static_cast<int>(keypoints[i].pt.x / cell),
                                static_cast<int>(keypoints[i].pt.y / cell)),
                 static_cast<int>(i));
  }
  std::vector<char> seen(points_.size(), 0);
  for (int id : k.point_of_keypoint) {
    if (id >= 0) seen[static_cast<size_t>(id)] = 1;
  }
  const std::vector<int> segment = SegmentKeyframes();
  const size_t window = std::min(segment.size(), static_cast<size_t>(options_.window));
  const double ratio_sq = options_.match.ratio * options_.match.ratio;
  const double radius_sq = options_.search_radius_px * options_.search_radius_px;
  int found = 0;
  for (size_t w = segment.size() - window; w < segment.size(); ++w) {
    const int other = segment[w];
    if (other == keyframe) continue;
    for (int id : keyframes_[static_cast<size_t>(other)].point_of_keypoint) {
      if (id < 0 || seen[static_cast<size_t>(id)] || !points_[static_cast<size_t>(id)].valid) {
        continue;
      }
      seen[static_cast<size_t>(id)] = 1;
      WalkPoint& point = points_[static_cast<size_t>(id)];
      const Eigen::Vector3d x = k.cam_from_segment * point.position_in_segment;
      if (x.z() <= 0) continue;
      const Eigen::Vector2d pixel = Project(K_, x);
      const WalkPoint::Observation& newest = point.observations.back();
      const cv::Mat& descriptors =
          keyframes_[static_cast<size_t>(newest.keyframe)].features.descriptors;
      if (newest.keypoint >= descriptors.rows) continue;  // Released (older than the window).
      const cv::Mat reference = descriptors.row(newest.keypoint);
      const int cx = static_cast<int>(pixel.x() / cell);
      const int cy = static_cast<int>(pixel.y() / cell);
      double best = std::numeric_limits<double>::infinity(), second = best;
      int best_keypoint = -1;
      for (int gx = cx - 1; gx <= cx + 1; ++gx) {
        for (int gy = cy - 1; gy <= cy + 1; ++gy) {
          const auto [first, last] = grid.equal_range({gx, gy});
          for (auto it = first; it != last; ++it) {
            const cv::Point2f& p = keypoints[static_cast<size_t>(it->second)].pt;
            if ((Eigen::Vector2d(p.x, p.y) - pixel).squaredNorm() > radius_sq) continue;
            const double d =
                cv::norm(reference, k.features.descriptors.row(it->second), cv::NORM_L2SQR);
            if (d < best) {
              second = best;
              best = d;
              best_keypoint = it->second;
            } else if (d < second) {
              second = d;
            }
          }
        }
      }
      if (best_keypoint < 0 || k.point_of_keypoint[static_cast<size_t>(best_keypoint)] >= 0) {
        continue;
      }
      if (std::isfinite(second) && best > ratio_sq * second) continue;
      // Lowe's ratio against the runner-up in the radius; a lone candidate must still be as
      // near as a ratio-passing match would be to the reference's own scale (its norm).
      if (!std::isfinite(second) && best > ratio_sq * cv::norm(reference, cv::NORM_L2SQR)) {
        continue;
      }
      point.observations.push_back({keyframe, best_keypoint});
      k.point_of_keypoint[static_cast<size_t>(best_keypoint)] = id;
      ++found;
    }
  }
  return found;
}

int WalkMap::TriangulateWith(int keyframe, int other, const std::vector<Match>& matches) {
  WalkKeyframe& k = keyframes_[static_cast<size_t>(keyframe)];
  WalkKeyframe& o = keyframes_[static_cast<size_t>(other)];
  // Triangulated in `o`'s camera: B = k_from_o.
  const Eigen::Isometry3d k_from_o = k.cam_from_segment * o.cam_from_segment.inverse();
  RelativePose pose;
  pose.rotation = k_from_o.linear();
  pose.translation = k_from_o.translation();
  const Eigen::Matrix3d k_inv = K_.inverse();
  int added = 0;
  for (const Match& m : matches) {
    const int point_o = o.point_of_keypoint[static_cast<size_t>(m.index_a)];
    const int point_k = k.point_of_keypoint[static_cast<size_t>(m.index_b)];
    if (point_o >= 0) continue;
    if (point_k >= 0) {
      // The new keyframe's keypoint already sees a map point (registered against a newer
      // keyframe): the match adds `other`'s observation of it where that reprojects, which
      // lengthens the track the bundle adjustment constrains.
      WalkPoint& point = points_[static_cast<size_t>(point_k)];
      const Eigen::Vector3d x = o.cam_from_segment * point.position_in_segment;
      if (x.z() > 0 &&
          (Project(K_, x) - Pixel(other, m.index_a)).norm() <= options_.max_reprojection_px) {
        point.observations.push_back({other, m.index_a});
        o.point_of_keypoint[static_cast<size_t>(m.index_a)] = point_k;
      }
      continue;
    }
    const Eigen::Vector2d pixel_o = Pixel(other, m.index_a);
    const Eigen::Vector2d pixel_k = Pixel(keyframe, m.index_b);
    const Eigen::Vector2d x_o = (k_inv * pixel_o.homogeneous()).hnormalized();
    const Eigen::Vector2d x_k = (k_inv * pixel_k.homogeneous()).hnormalized();
    const Eigen::Vector3d p_o =
        RefineTriangulation(TriangulateLinear(x_o, x_k, pose), x_o, x_k, pose);
    const Eigen::Vector3d p_k = k_from_o * p_o;
    if (p_o.z() <= 0 || p_k.z() <= 0) continue;
    const Eigen::Vector2d errors = ReprojectionErrorsPx(K_, p_o, p_k, pixel_o, pixel_k);
    if (errors.maxCoeff() > options_.max_reprojection_px) continue;
    if (TriangulationAngleDeg(p_o, pose) < options_.min_triangulation_angle_deg) continue;
    WalkPoint point;
    point.segment = segment_;
    point.position_in_segment = o.cam_from_segment.inverse() * p_o;
    point.observations = {{other, m.index_a}, {keyframe, m.index_b}};
    const int id = static_cast<int>(points_.size());
    points_.push_back(std::move(point));
    o.point_of_keypoint[static_cast<size_t>(m.index_a)] = id;
    k.point_of_keypoint[static_cast<size_t>(m.index_b)] = id;
    ++added;
  }
  return added;
}

void WalkMap::AdjustWindow(WalkKeyframeSummary* summary) {
  const std::vector<int> segment = SegmentKeyframes();
  const size_t window = std::min(segment.size(), static_cast<size_t>(options_.window));
  const std::vector<int> adjusted(segment.end() - static_cast<std::ptrdiff_t>(window),
                                  segment.end());
  LocalBundleProblem problem;
  problem.k = K_;
  std::map<int, int> pose_of_keyframe;
  auto add_pose = [&](int keyframe, bool fixed) {
    const auto [it, inserted] =
        pose_of_keyframe.emplace(keyframe, static_cast<int>(problem.cam_from_world.size()));
    if (inserted) {
      problem.cam_from_world.push_back(keyframes_[static_cast<size_t>(keyframe)].cam_from_segment);
      problem.pose_fixed.push_back(fixed);
    }
    return it->second;
  };
  // The window's two oldest keyframes are fixed: the gauge and the scale.
  for (size_t i = 0; i < adjusted.size(); ++i) add_pose(adjusted[i], i < 2);
  std::map<int, int> point_of_id;
  for (int keyframe : adjusted) {
    for (int id : keyframes_[static_cast<size_t>(keyframe)].point_of_keypoint) {
      if (id < 0 || !points_[static_cast<size_t>(id)].valid) continue;
      if (point_of_id.emplace(id, static_cast<int>(problem.points_in_world.size())).second) {
        problem.points_in_world.push_back(points_[static_cast<size_t>(id)].position_in_segment);
      }
    }
  }
  for (const auto& [id, p] : point_of_id) {
    for (const WalkPoint::Observation& o : points_[static_cast<size_t>(id)].observations) {
      // Keyframes outside the window see the point from fixed poses.
      const int pose = add_pose(o.keyframe, true);
      problem.observations.push_back({pose, p, Pixel(o.keyframe, o.keypoint)});
    }
  }
  const LocalBundleSummary bundle = AdjustLocalBundle(options_.bundle, &problem);
  if (!bundle.ran) return;
  summary->bundle_rms_px = bundle.final_rms_px;
  for (const auto& [keyframe, pose] : pose_of_keyframe) {
    keyframes_[static_cast<size_t>(keyframe)].cam_from_segment =
        problem.cam_from_world[static_cast<size_t>(pose)];
  }
  // Points back; observations the adjusted map no longer explains are dropped, and a point
  // left with fewer than two is invalid.
  for (const auto& [id, p] : point_of_id) {
    WalkPoint& point = points_[static_cast<size_t>(id)];
    point.position_in_segment = problem.points_in_world[static_cast<size_t>(p)];
    std::vector<WalkPoint::Observation> kept;
    for (const WalkPoint::Observation& o : point.observations) {
      const Eigen::Vector3d x =
          keyframes_[static_cast<size_t>(o.keyframe)].cam_from_segment * point.position_in_segment;
      if (x.z() > 0 &&
          (Project(K_, x) - Pixel(o.keyframe, o.keypoint)).norm() <= options_.max_reprojection_px) {
        kept.push_back(o);
      } else {
        keyframes_[static_cast<size_t>(o.keyframe)]
            .point_of_keypoint[static_cast<size_t>(o.keypoint)] = -1;
      }
    }
    point.observations = std::move(kept);
    if (point.observations.size() < 2) {
      point.valid = false;
      for (const WalkPoint::Observation& o : point.observations) {
        keyframes_[static_cast<size_t>(o.keyframe)]
            .point_of_keypoint[static_cast<size_t>(o.keypoint)] = -1;
      }
    }
  }
}

}  // namespace mm
