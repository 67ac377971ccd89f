#include "map/walk_map.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <map>
#include <numeric>
#include <opencv2/imgproc.hpp>
#include <set>
#include <utility>

#include "base/stats.h"
#include "map/pose_graph.h"
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

// PTAM's keyframe thumbnail (Klein & Murray 2008, sec. 6): the image shrunk to 40x30 and
// blurred, zero mean and unit norm, so that the dot product of two is their correlation.
cv::Mat Thumbnail(const cv::Mat& gray) {
  cv::Mat small, blurred;
  cv::resize(gray, small, cv::Size(40, 30), 0, 0, cv::INTER_AREA);
  small.convertTo(small, CV_32F);
  cv::GaussianBlur(small, blurred, cv::Size(0, 0), 1.0);
  blurred -= cv::mean(blurred)[0];
  const double norm = cv::norm(blurred);
  if (norm > 0) blurred /= norm;
  return blurred;
}

double Correlation(const cv::Mat& a, const cv::Mat& b) {
  if (a.empty() || b.empty()) return -1.0;
  return a.dot(b);
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
  if (!(prior_search_radius_px >= 0)) return "prior_search_radius_px: must be >= 0";
  if (relocalization_candidates < 0) return "relocalization_candidates: must be >= 0";
  if (kept_descriptors < 0) return "kept_descriptors: must be >= 0";
  if (max_lost_keyframes < 0) return "max_lost_keyframes: must be >= 0";
  if (min_merge_points < 3) return "min_merge_points: must be >= 3";
  if (min_bridge_points < 3) return "min_bridge_points: must be >= 3";
  if (loop_min_gap_keyframes < 0) return "loop_min_gap_keyframes: must be >= 0";
  if (min_loop_inliers < 6) return "min_loop_inliers: must be >= 6";
  if (loop_candidates < 0) return "loop_candidates: must be >= 0";
  if (global_bundle_max_keyframes < 0) return "global_bundle_max_keyframes: must be >= 0";
  if (global_bundle_max_observations < 0) {
    return "global_bundle_max_observations: must be >= 0";
  }
  if (global_bundle_apply_after < -1) return "global_bundle_apply_after: must be >= -1";
  if (std::string p = pose_graph.Check(); !p.empty()) return "pose_graph." + p;
  if (std::string p = global_bundle.Check(); !p.empty()) return "global_bundle." + p;
  if (window < 3) return "window: must be >= 3 (two keyframes are fixed)";
  return {};
}

WalkMap::WalkMap(const Eigen::Matrix3d& K, const WalkOptions& options) : K_(K), options_(options) {}

Eigen::Vector2d WalkMap::Pixel(int keyframe, int keypoint) const {
  return keyframes_[static_cast<size_t>(keyframe)]
      .keypoint_pixels[static_cast<size_t>(keypoint)]
      .cast<double>();
}

int WalkMap::segments() const {
  std::set<int> alive;
  for (const WalkKeyframe& k : keyframes_) {
    if (k.registered) alive.insert(k.segment);
  }
  return static_cast<int>(alive.size());
}

int WalkMap::newest_keyframe() const {
  for (int i = static_cast<int>(keyframes_.size()) - 1; i >= 0; --i) {
    const WalkKeyframe& k = keyframes_[static_cast<size_t>(i)];
    if (k.registered && k.segment == segment_) return i;
  }
  return -1;
}

std::vector<int> WalkMap::SegmentKeyframes() const {
  std::vector<int> out;
  for (int i = 0; i < static_cast<int>(keyframes_.size()); ++i) {
    const WalkKeyframe& k = keyframes_[static_cast<size_t>(i)];
    if (k.registered && k.segment == segment_) out.push_back(i);
  }
  return out;
}

std::vector<int> WalkMap::LocalKeyframes(int newest, int count) const {
  // Covisibility (ORB-SLAM's covisibility graph, Mur-Artal et al. 2015, sec. III-D): the
  // keyframes sharing the most map points with `newest`; its registered predecessors in the
  // segment fill up what sharing does not.
  const WalkKeyframe& n = keyframes_[static_cast<size_t>(newest)];
  std::map<int, int> shared;
  for (int id : n.point_of_keypoint) {
    if (id < 0 || !points_[static_cast<size_t>(id)].valid) continue;
    for (const WalkPoint::Observation& o : points_[static_cast<size_t>(id)].observations) {
      if (o.keyframe != newest) ++shared[o.keyframe];
    }
  }
  std::vector<std::pair<int, int>> ranked;  // (-shared, keyframe)
  for (const auto& [keyframe, count_shared] : shared) {
    const WalkKeyframe& k = keyframes_[static_cast<size_t>(keyframe)];
    if (k.registered && k.segment == n.segment) ranked.emplace_back(-count_shared, keyframe);
  }
  std::sort(ranked.begin(), ranked.end());
  std::set<int> chosen = {newest};
  for (const auto& [negative, keyframe] : ranked) {
    if (static_cast<int>(chosen.size()) >= count) break;
    chosen.insert(keyframe);
  }
  for (int i = newest - 1; i >= 0 && static_cast<int>(chosen.size()) < count; --i) {
    const WalkKeyframe& k = keyframes_[static_cast<size_t>(i)];
    if (k.registered && k.segment == n.segment) chosen.insert(i);
  }
  return {chosen.begin(), chosen.end()};
}

void WalkMap::StartSegment(int keyframe) {
  segment_ = next_segment_++;
  WalkKeyframe& k = keyframes_[static_cast<size_t>(keyframe)];
  k.segment = segment_;
  k.registered = true;
  k.joined = keyframe == 0;
  k.cam_from_segment = Eigen::Isometry3d::Identity();
}

cv::Mat WalkMap::Descriptor(int keyframe, int keypoint) const {
  const WalkKeyframe& k = keyframes_[static_cast<size_t>(keyframe)];
  if (keypoint < k.features.descriptors.rows) return k.features.descriptors.row(keypoint);
  const auto it = std::lower_bound(k.kept_keypoints.begin(), k.kept_keypoints.end(), keypoint);
  if (it == k.kept_keypoints.end() || *it != keypoint) return {};
  cv::Mat out;
  k.kept_descriptors.row(static_cast<int>(it - k.kept_keypoints.begin())).convertTo(out, CV_32F);
  return out;
}

cv::Mat WalkMap::PointDescriptors(int keyframe, std::vector<int>* keypoints) const {
  const WalkKeyframe& k = keyframes_[static_cast<size_t>(keyframe)];
  keypoints->clear();
  cv::Mat out;
  const bool full = !k.features.descriptors.empty();
  for (size_t i = 0; i < k.point_of_keypoint.size(); ++i) {
    const int id = k.point_of_keypoint[i];
    if (id < 0 || !points_[static_cast<size_t>(id)].valid) continue;
    if (full) {
      keypoints->push_back(static_cast<int>(i));
      continue;
    }
    const auto it =
        std::lower_bound(k.kept_keypoints.begin(), k.kept_keypoints.end(), static_cast<int>(i));
    if (it != k.kept_keypoints.end() && *it == static_cast<int>(i)) {
      keypoints->push_back(static_cast<int>(i));
    }
  }
  out.create(static_cast<int>(keypoints->size()), 128, CV_32F);
  for (size_t r = 0; r < keypoints->size(); ++r) {
    Descriptor(keyframe, (*keypoints)[r]).copyTo(out.row(static_cast<int>(r)));
  }
  return out;
}

void WalkMap::ReleaseDescriptors(int keyframe) {
  WalkKeyframe& k = keyframes_[static_cast<size_t>(keyframe)];
  if (k.features.descriptors.empty()) return;
  // The keypoints of the map points seen most often (the most stable), at most
  // `kept_descriptors` of them: enough for a relocalisation's PnP, 128 bytes each.
  std::vector<std::pair<int, int>> ranked;  // (-observations, keypoint)
  for (size_t i = 0; i < k.point_of_keypoint.size(); ++i) {
    const int id = k.point_of_keypoint[i];
    if (id < 0 || !points_[static_cast<size_t>(id)].valid) continue;
    ranked.emplace_back(-static_cast<int>(points_[static_cast<size_t>(id)].observations.size()),
                        static_cast<int>(i));
  }
  const size_t count = std::min(ranked.size(), static_cast<size_t>(options_.kept_descriptors));
  std::partial_sort(ranked.begin(), ranked.begin() + static_cast<std::ptrdiff_t>(count),
                    ranked.end());
  std::vector<int> kept;
  for (size_t r = 0; r < count; ++r) kept.push_back(ranked[r].second);
  std::sort(kept.begin(), kept.end());
  cv::Mat rows(static_cast<int>(kept.size()), k.features.descriptors.cols, CV_32F);
  for (size_t r = 0; r < kept.size(); ++r) {
    k.features.descriptors.row(kept[r]).copyTo(rows.row(static_cast<int>(r)));
  }
  // SIFT's descriptor entries are 0..255 (OpenCV's and ours scale by 512 and saturate).
  rows.convertTo(k.kept_descriptors, CV_8U);
  k.kept_keypoints = std::move(kept);
  k.features = Features{};
}

WalkKeyframeSummary WalkMap::AddKeyframe(const cv::Mat& gray, double timestamp_s,
                                         const Eigen::Isometry3d* cam_from_segment_prior) {
  const auto start = Clock::now();
  WalkKeyframeSummary summary;
  summary.index = static_cast<int>(keyframes_.size());
  WalkKeyframe keyframe;
  keyframe.timestamp_s = timestamp_s;
  keyframe.features = ExtractSift(gray, options_.sift);
  keyframe.thumbnail = Thumbnail(gray);
  summary.sift_s = SecondsSince(start);
  keyframe.point_of_keypoint.assign(keyframe.features.keypoints.size(), -1);
  keyframe.keypoint_pixels.reserve(keyframe.features.keypoints.size());
  for (const cv::KeyPoint& kp : keyframe.features.keypoints) {
    keyframe.keypoint_pixels.emplace_back(kp.pt.x, kp.pt.y);
  }
  keyframe.segment = segment_;
  keyframes_.push_back(std::move(keyframe));
  const int index = summary.index;
  WalkKeyframe& k = keyframes_.back();

  const std::vector<int> segment = SegmentKeyframes();
  if (segment.empty()) {
    StartSegment(index);
  } else if (segment.size() == 1) {
    if (Initialize(index, &summary)) {
      k.joined = keyframes_[static_cast<size_t>(segment.front())].joined;
    } else {
      // The segment's lone keyframe and this one do not make a pair: start again from here
      // (the lone keyframe stays a segment of one).
      StartSegment(index);
      summary.failure = "new segment: " + summary.failure;
    }
  } else if (Register(index, segment_ == k.segment ? cam_from_segment_prior : nullptr, &summary) ||
             Bridge(index, &summary)) {
    k.joined = true;
  } else {
    // Relocalisation against every earlier keyframe of every segment (the newest ones were
    // just tried).
    const std::string why = summary.failure;
    const int count = std::min<int>(options_.match_keyframes, static_cast<int>(segment.size()));
    const std::vector<int> tried(segment.end() - count, segment.end());
    Eigen::Isometry3d pose;
    std::vector<std::pair<int, int>> inliers;
    std::vector<Match> matches;
    const int candidate =
        Relocalize(index, tried, Candidates::kAll, options_.relocalization_candidates,
                   options_.min_pnp_inliers, &pose, &inliers, &matches);
    if (candidate >= 0) {
      summary.failure.clear();
      summary.relocalized_to = candidate;
      summary.pnp_inliers = static_cast<int>(inliers.size());
      ++relocalizations_;
      Accept(index, pose, keyframes_[static_cast<size_t>(candidate)].segment, inliers, &summary);
      summary.new_points += TriangulateWith(index, candidate, matches);
      k.joined = true;
    } else if (lost_run_ >= options_.max_lost_keyframes) {
      StartSegment(index);
      summary.failure =
          "new segment after " + std::to_string(lost_run_) + " lost keyframes: " + why;
      lost_run_ = 0;
    } else {
      k.registered = false;
      summary.failure = "lost: " + why;
      ++lost_run_;
      ++lost_keyframes_;
    }
  }
  if (k.registered && summary.failure.empty()) {
    lost_run_ = 0;
    if (segment.size() >= 2) {
      const auto bundle_start = Clock::now();
      AdjustWindow(index, &summary);
      summary.bundle_s = SecondsSince(bundle_start);
    }
    if (segments() > 1 && segment.size() >= 2) {
      // A merge moves the segment: the background adjustment of it is applied first.
      if (segment_bundle_.running()) ApplySegmentBundle(&summary);
      TryMerge(index, &summary);
    }
    if (summary.merged_segment < 0 && segment.size() >= 2) TryCloseLoop(index, &summary);
  }
  if (segment_bundle_.running()) {
    const int after = options_.global_bundle_apply_after;
    const int since = index - segment_bundle_snapshot_.loop_keyframe;
    if (after >= 0 ? since >= after : segment_bundle_.done()) ApplySegmentBundle(&summary);
  }
  summary.registered = k.registered;
  summary.segment = k.segment;
  // Full descriptors are read only for the newest keyframes (matching) and the window (the
  // search by projection): older ones keep only those of their map points' keypoints, 8-bit,
  // which bounds a long walk's memory (their pixels stay for the BA).
  const int keep = std::max(options_.window, options_.match_keyframes) + 1;
  if (index >= keep) ReleaseDescriptors(index - keep);
  summary.time_s = SecondsSince(start);
  summary.pose_s = summary.time_s - summary.sift_s - summary.matching_s - summary.bundle_s;
  return summary;
}

TwoViewResult WalkMap::TwoView(int a, int b, const std::vector<Match>& matches) const {
  std::vector<Eigen::Vector2d> pixels_a, pixels_b;
  for (const Match& m : matches) {
    pixels_a.push_back(Pixel(a, m.index_a));
    pixels_b.push_back(Pixel(b, m.index_b));
  }
  TwoViewOptions two_view = options_.two_view;
  two_view.seed = options_.seed + static_cast<unsigned>(b);
  return EstimateTwoView(pixels_a, pixels_b, K_, two_view);
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
  const TwoViewResult pair = TwoView(first, keyframe, matches);
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

bool WalkMap::Register(int keyframe, const Eigen::Isometry3d* prior, WalkKeyframeSummary* summary) {
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
  summary->matches_3d = static_cast<int>(point_of_new_keypoint.size());
  if (prior != nullptr && options_.prior_search_radius_px > 0) {
    // The local map under the tracker's pose: more candidates than one keyframe's matches
    // give, the older keyframes' points included.
    std::vector<std::pair<int, int>> found;
    const std::vector<int> local = LocalKeyframes(segment.back(), options_.window);
    SearchByProjection(keyframe, local, options_.prior_search_radius_px, *prior, &found, false);
    std::set<int> used;
    for (const auto& [keypoint, id] : point_of_new_keypoint) used.insert(id);
    for (const auto& [keypoint, id] : found) {
      if (used.count(id) || point_of_new_keypoint.count(keypoint)) continue;
      point_of_new_keypoint.emplace(keypoint, id);
      used.insert(id);
      ++summary->prior_matches;
    }
    summary->from_prior = true;
  }
  std::vector<Eigen::Vector3d> object;
  std::vector<Eigen::Vector2d> image;
  std::vector<std::pair<int, int>> correspondence;  // (new keypoint, point)
  for (const auto& [keypoint, id] : point_of_new_keypoint) {
    object.push_back(points_[static_cast<size_t>(id)].position_in_segment);
    image.push_back(Pixel(keyframe, keypoint));
    correspondence.emplace_back(keypoint, id);
  }
  if (static_cast<int>(object.size()) < options_.min_pnp_inliers) {
    summary->failure = "registration: " + std::to_string(object.size()) +
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
                       " PnP inliers of " + std::to_string(object.size()) + " (need " +
                       std::to_string(options_.min_pnp_inliers) + ")";
    return false;
  }
  Eigen::Isometry3d cam_from_segment = Eigen::Isometry3d::Identity();
  cam_from_segment.linear() = pose.rotation;
  cam_from_segment.translation() = pose.translation;
  Accept(keyframe, cam_from_segment, segment_, correspondence, summary);
  // New points from the matches to the newest keyframes that have no point yet.
  for (int j = 0; j < count; ++j) {
    const int other = segment[segment.size() - 1 - static_cast<size_t>(j)];
    summary->new_points += TriangulateWith(keyframe, other, matches_to[static_cast<size_t>(j)]);
  }
  return true;
}

bool WalkMap::Bridge(int keyframe, WalkKeyframeSummary* summary) {
  const std::vector<int> segment = SegmentKeyframes();
  const int newest = segment.back();
  const WalkKeyframe& a = keyframes_[static_cast<size_t>(newest)];
  const WalkKeyframe& b = keyframes_[static_cast<size_t>(keyframe)];
  if (a.features.descriptors.empty() || b.features.descriptors.empty()) return false;
  const std::vector<Match> matches =
      MatchDescriptors(a.features.descriptors, b.features.descriptors, options_.match);
  const TwoViewResult pair = TwoView(newest, keyframe, matches);
  if (!pair.success) return false;
  // The pair's unit baseline in map units: the map's depth over the pair's at the points both
  // have (in the newest keyframe's camera), their median; they must agree (MAD within 10 %).
  std::vector<double> ratios;
  std::vector<std::pair<int, int>> seen;  // (new keypoint, map point)
  for (size_t i = 0; i < pair.points_in_cam_a.size(); ++i) {
    const Match& m = matches[static_cast<size_t>(pair.point_correspondence[i])];
    const int id = a.point_of_keypoint[static_cast<size_t>(m.index_a)];
    if (id < 0 || !points_[static_cast<size_t>(id)].valid) continue;
    const double z_map =
        (a.cam_from_segment * points_[static_cast<size_t>(id)].position_in_segment).z();
    const double z_pair = pair.points_in_cam_a[i].z();
    if (z_map <= 0 || z_pair <= 0) continue;
    ratios.push_back(z_map / z_pair);
    seen.emplace_back(m.index_b, id);
  }
  if (static_cast<int>(ratios.size()) < options_.min_bridge_points) return false;
  const double scale = MedianOf(ratios);
  std::vector<double> deviations;
  deviations.reserve(ratios.size());
  for (double r : ratios) deviations.push_back(std::abs(r / scale - 1.0));
  if (!(scale > 0) || MedianOf(std::move(deviations)) > 0.1) return false;
  Eigen::Isometry3d b_from_a = Eigen::Isometry3d::Identity();
  b_from_a.linear() = pair.rotation;
  b_from_a.translation() = scale * pair.translation;
  summary->failure.clear();
  summary->bridged = true;
  summary->pnp_inliers = static_cast<int>(seen.size());
  Accept(keyframe, b_from_a * a.cam_from_segment, segment_, seen, summary);
  summary->new_points += TriangulateWith(keyframe, newest, matches);
  return true;
}

void WalkMap::Accept(int keyframe, const Eigen::Isometry3d& cam_from_segment, int segment,
                     const std::vector<std::pair<int, int>>& inliers,
                     WalkKeyframeSummary* summary) {
  WalkKeyframe& k = keyframes_[static_cast<size_t>(keyframe)];
  k.cam_from_segment = cam_from_segment;
  k.segment = segment;
  k.registered = true;
  segment_ = segment;
  // Observations of the map points, re-checked under the refined pose.
  for (const auto& [keypoint, id] : inliers) {
    WalkPoint& point = points_[static_cast<size_t>(id)];
    if (!point.valid || k.point_of_keypoint[static_cast<size_t>(keypoint)] >= 0) continue;
    const Eigen::Vector3d x = k.cam_from_segment * point.position_in_segment;
    if (x.z() <= 0 ||
        (Project(K_, x) - Pixel(keyframe, keypoint)).norm() > options_.pnp_reprojection_px) {
      continue;
    }
    point.observations.push_back({keyframe, keypoint});
    k.point_of_keypoint[static_cast<size_t>(keypoint)] = id;
  }
  if (options_.search_radius_px > 0) {
    const std::vector<int> local = LocalKeyframes(keyframe, options_.window + 1);
    summary->projected_matches = SearchByProjection(keyframe, local, options_.search_radius_px,
                                                    k.cam_from_segment, nullptr, true);
  }
}

int WalkMap::SearchByProjection(int keyframe, const std::vector<int>& local, double radius_px,
                                const Eigen::Isometry3d& cam_from_segment,
                                std::vector<std::pair<int, int>>* found_pairs, bool observe) {
  WalkKeyframe& k = keyframes_[static_cast<size_t>(keyframe)];
  const std::vector<cv::KeyPoint>& keypoints = k.features.keypoints;
  if (keypoints.empty() || radius_px <= 0) return 0;
  // Keypoints without a point, bucketed in cells of the search radius.
  const double cell = std::max(radius_px, 1.0);
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
  std::vector<char> taken(keypoints.size(), 0);
  const double ratio_sq = options_.match.ratio * options_.match.ratio;
  const double radius_sq = radius_px * radius_px;
  int found = 0;
  for (const int other : local) {
    if (other == keyframe) continue;
    for (int id : keyframes_[static_cast<size_t>(other)].point_of_keypoint) {
      if (id < 0 || seen[static_cast<size_t>(id)] || !points_[static_cast<size_t>(id)].valid) {
        continue;
      }
      seen[static_cast<size_t>(id)] = 1;
      WalkPoint& point = points_[static_cast<size_t>(id)];
      const Eigen::Vector3d x = cam_from_segment * point.position_in_segment;
      if (x.z() <= 0) continue;
      const Eigen::Vector2d pixel = Project(K_, x);
      if (pixel.x() < -radius_px || pixel.y() < -radius_px) continue;
      const WalkPoint::Observation& newest = point.observations.back();
      const cv::Mat reference = Descriptor(newest.keyframe, newest.keypoint);
      if (reference.empty()) continue;
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
      if (best_keypoint < 0 || k.point_of_keypoint[static_cast<size_t>(best_keypoint)] >= 0 ||
          taken[static_cast<size_t>(best_keypoint)]) {
        continue;
      }
      if (std::isfinite(second) && best > ratio_sq * second) continue;
      // Lowe's ratio against the runner-up in the radius; a lone candidate must still be as
      // near as a ratio-passing match would be to the reference's own scale (its norm).
      if (!std::isfinite(second) && best > ratio_sq * cv::norm(reference, cv::NORM_L2SQR)) {
        continue;
      }
      taken[static_cast<size_t>(best_keypoint)] = 1;
      if (found_pairs != nullptr) found_pairs->emplace_back(best_keypoint, id);
      if (observe) {
        point.observations.push_back({keyframe, best_keypoint});
        k.point_of_keypoint[static_cast<size_t>(best_keypoint)] = id;
      }
      ++found;
    }
  }
  return found;
}

int WalkMap::Relocalize(int keyframe, const std::vector<int>& skip, Candidates which, int tries,
                        int min_inliers, Eigen::Isometry3d* cam_from_segment,
                        std::vector<std::pair<int, int>>* inliers, std::vector<Match>* matches) {
  if (tries <= 0) return -1;
  const WalkKeyframe& k = keyframes_[static_cast<size_t>(keyframe)];
  // A loop's candidate must look at least as much like the keyframe as its least similar
  // neighbour does (DBoW's minimum covisible score, Galvez-Lopez & Tardos 2012).
  double min_score = -2.0;
  if (which == Candidates::kLoop) {
    min_score = 2.0;
    for (int i : skip) {
      if (i != keyframe && keyframes_[static_cast<size_t>(i)].registered) {
        min_score = std::min(
            min_score, Correlation(k.thumbnail, keyframes_[static_cast<size_t>(i)].thumbnail));
      }
    }
    if (min_score > 1.0) return -1;
  }
  std::vector<std::pair<double, int>> ranked;  // (-correlation, keyframe)
  for (int i = 0; i < keyframe; ++i) {
    const WalkKeyframe& c = keyframes_[static_cast<size_t>(i)];
    if (!c.registered || std::find(skip.begin(), skip.end(), i) != skip.end()) continue;
    if (which == Candidates::kOtherSegments && c.segment == segment_) continue;
    if (which == Candidates::kLoop &&
        (c.segment != k.segment || i > keyframe - options_.loop_min_gap_keyframes)) {
      continue;
    }
    const double score = Correlation(k.thumbnail, c.thumbnail);
    if (score < min_score) continue;
    ranked.emplace_back(-score, i);
  }
  std::sort(ranked.begin(), ranked.end());
  tries = std::min<int>(tries, static_cast<int>(ranked.size()));
  for (int t = 0; t < tries; ++t) {
    const int candidate = ranked[static_cast<size_t>(t)].second;
    std::vector<int> keypoints;
    const cv::Mat descriptors = PointDescriptors(candidate, &keypoints);
    if (static_cast<int>(keypoints.size()) < min_inliers) continue;
    const std::vector<Match> found =
        MatchDescriptors(descriptors, k.features.descriptors, options_.match);
    if (static_cast<int>(found.size()) < min_inliers) continue;
    const WalkKeyframe& c = keyframes_[static_cast<size_t>(candidate)];
    std::vector<Eigen::Vector3d> object;
    std::vector<Eigen::Vector2d> image;
    std::vector<std::pair<int, int>> correspondence;
    std::vector<Match> in_candidate;  // index_a: the candidate's keypoint.
    for (const Match& m : found) {
      const int keypoint_c = keypoints[static_cast<size_t>(m.index_a)];
      const int id = c.point_of_keypoint[static_cast<size_t>(keypoint_c)];
      object.push_back(points_[static_cast<size_t>(id)].position_in_segment);
      image.push_back(Pixel(keyframe, m.index_b));
      correspondence.emplace_back(m.index_b, id);
      Match mc = m;
      mc.index_a = keypoint_c;
      in_candidate.push_back(mc);
    }
    const PnpRansacPose pose = SolvePnpRansacRefined(object, image, K_,
                                                     {.threshold_px = options_.pnp_reprojection_px,
                                                      .iterations = options_.pnp_iterations,
                                                      .confidence = 0.9999,
                                                      .sqpnp = true});
    if (!pose.found || static_cast<int>(pose.inliers.size()) < min_inliers) continue;
    cam_from_segment->linear() = pose.rotation;
    cam_from_segment->translation() = pose.translation;
    inliers->clear();
    for (int i : pose.inliers) inliers->push_back(correspondence[static_cast<size_t>(i)]);
    *matches = std::move(in_candidate);
    return candidate;
  }
  return -1;
}

bool WalkMap::FitSim3(int keyframe, const Eigen::Isometry3d& cam_from_other,
                      const std::vector<std::pair<int, int>>& inliers, Eigen::Matrix4d* sim3,
                      std::vector<std::pair<int, int>>* agreeing) const {
  const WalkKeyframe& k = keyframes_[static_cast<size_t>(keyframe)];
  std::vector<std::pair<int, int>> pairs;  // (this keyframe's point, the other's)
  for (const auto& [keypoint, id_other] : inliers) {
    const int id_this = k.point_of_keypoint[static_cast<size_t>(keypoint)];
    if (id_this >= 0 && id_this != id_other && points_[static_cast<size_t>(id_this)].valid) {
      pairs.emplace_back(id_this, id_other);
    }
  }
  *agreeing = pairs;
  for (int round = 0; round < 3; ++round) {
    if (static_cast<int>(agreeing->size()) < options_.min_merge_points) return false;
    Eigen::Matrix3Xd src(3, static_cast<Eigen::Index>(agreeing->size()));
    Eigen::Matrix3Xd dst(3, static_cast<Eigen::Index>(agreeing->size()));
    for (size_t i = 0; i < agreeing->size(); ++i) {
      src.col(static_cast<Eigen::Index>(i)) =
          points_[static_cast<size_t>((*agreeing)[i].first)].position_in_segment;
      dst.col(static_cast<Eigen::Index>(i)) =
          points_[static_cast<size_t>((*agreeing)[i].second)].position_in_segment;
    }
    *sim3 = Eigen::umeyama(src, dst, true);
    std::vector<std::pair<int, int>> next;
    for (const auto& [id_this, id_other] : pairs) {
      const Eigen::Vector3d mapped =
          (*sim3 * points_[static_cast<size_t>(id_this)].position_in_segment.homogeneous())
              .head<3>();
      const Eigen::Vector3d& target = points_[static_cast<size_t>(id_other)].position_in_segment;
      const double depth = (cam_from_other * target).z();
      if (depth > 0 && (mapped - target).norm() <= 0.05 * depth) {
        next.emplace_back(id_this, id_other);
      }
    }
    *agreeing = std::move(next);
  }
  return static_cast<int>(agreeing->size()) >= options_.min_merge_points;
}

void WalkMap::FusePoints(const std::vector<std::pair<int, int>>& pairs) {
  for (const auto& [id_this, id_other] : pairs) {
    WalkPoint& from = points_[static_cast<size_t>(id_this)];
    WalkPoint& into = points_[static_cast<size_t>(id_other)];
    if (!from.valid || !into.valid || id_this == id_other) continue;
    for (const WalkPoint::Observation& o : from.observations) {
      int& slot = keyframes_[static_cast<size_t>(o.keyframe)]
                      .point_of_keypoint[static_cast<size_t>(o.keypoint)];
      const bool sees_already =
          std::any_of(into.observations.begin(), into.observations.end(),
                      [&](const WalkPoint::Observation& q) { return q.keyframe == o.keyframe; });
      if (sees_already) {
        slot = -1;
        continue;
      }
      slot = id_other;
      into.observations.push_back(o);
    }
    from.observations.clear();
    from.valid = false;
  }
}

bool WalkMap::TryMerge(int keyframe, WalkKeyframeSummary* summary) {
  Eigen::Isometry3d cam_from_other;
  std::vector<std::pair<int, int>> inliers;
  std::vector<Match> matches;
  const int candidate =
      Relocalize(keyframe, {}, Candidates::kOtherSegments, options_.relocalization_candidates,
                 options_.min_pnp_inliers, &cam_from_other, &inliers, &matches);
  if (candidate < 0) return false;
  const int other = keyframes_[static_cast<size_t>(candidate)].segment;
  Eigen::Matrix4d sim3;
  std::vector<std::pair<int, int>> agreeing;
  if (!FitSim3(keyframe, cam_from_other, inliers, &sim3, &agreeing)) return false;
  const Sim3 other_from_this = Sim3::FromMatrix(sim3);
  const Sim3 this_from_other = other_from_this.Inverse();
  const int merged = segment_;
  for (WalkKeyframe& kf : keyframes_) {
    if (!kf.registered || kf.segment != merged) continue;
    // x_cam = T X_this = T S^-1 X_other: the similarity's camera pose (R, t / s).
    kf.cam_from_segment = (Sim3::FromIsometry(kf.cam_from_segment) * this_from_other).ToIsometry();
    kf.segment = other;
    kf.joined = true;
  }
  for (WalkPoint& p : points_) {
    if (p.segment != merged) continue;
    p.position_in_segment = other_from_this * p.position_in_segment;
    p.segment = other;
  }
  FusePoints(agreeing);
  segment_ = other;
  ++merges_;
  summary->merged_segment = merged;
  summary->segment = other;
  AdjustWindow(keyframe, summary);
  return true;
}

bool WalkMap::TryCloseLoop(int keyframe, WalkKeyframeSummary* summary) {
  if (options_.loop_min_gap_keyframes <= 0 || options_.loop_candidates <= 0) return false;
  if (last_loop_keyframe_ >= 0 && keyframe - last_loop_keyframe_ < options_.window) return false;
  // The last loop's adjustment still runs (ORB-SLAM, too, closes one loop at a time).
  if (segment_bundle_.running()) return false;
  // Candidates share no point with the keyframe (ORB-SLAM leaves out the keyframes connected
  // to it in the covisibility graph): a place seen again, not one still in view.
  const std::vector<int> neighbours = LocalKeyframes(keyframe, 2 * options_.window);
  std::set<int> connected(neighbours.begin(), neighbours.end());
  for (int id : keyframes_[static_cast<size_t>(keyframe)].point_of_keypoint) {
    if (id < 0 || !points_[static_cast<size_t>(id)].valid) continue;
    for (const WalkPoint::Observation& o : points_[static_cast<size_t>(id)].observations) {
      connected.insert(o.keyframe);
    }
  }
  const std::vector<int> skip(connected.begin(), connected.end());
  Eigen::Isometry3d cam_from_loop;
  std::vector<std::pair<int, int>> inliers;
  std::vector<Match> matches;
  const int loop = Relocalize(keyframe, skip, Candidates::kLoop, options_.loop_candidates,
                              options_.min_loop_inliers, &cam_from_loop, &inliers, &matches);
  if (loop < 0) return false;
  Eigen::Matrix4d sim3;
  std::vector<std::pair<int, int>> agreeing;
  if (!FitSim3(keyframe, cam_from_loop, inliers, &sim3, &agreeing)) return false;
  const auto start = Clock::now();
  last_loop_keyframe_ = keyframe;
  summary->loop_to = loop;
  // A loop that closes within the map's own noise (the keyframe within 1 % of its distance
  // to the loop keyframe, scale within 1 %, 0.5 deg) only joins the points: a pose graph and
  // a bundle adjustment of the whole segment would buy nothing for their CPU.
  const Sim3 loop_from_now = Sim3::FromMatrix(sim3);
  const Eigen::Vector3d centre =
      keyframes_[static_cast<size_t>(keyframe)].cam_from_segment.inverse().translation();
  const Eigen::Vector3d loop_centre =
      keyframes_[static_cast<size_t>(loop)].cam_from_segment.inverse().translation();
  const double shift = (loop_from_now * centre - centre).norm();
  if (shift <= 0.01 * std::max((centre - loop_centre).norm(), 1e-9) &&
      std::abs(loop_from_now.scale - 1.0) <= 0.01 &&
      loop_from_now.rotation.angularDistance(Eigen::Quaterniond::Identity()) <= 0.5 * M_PI / 180) {
    FusePoints(agreeing);
    ++loop_closures_;
    return true;
  }
  // X_loop = S X_now: the keyframe and its neighbours are moved by S^-1 onto the loop's side
  // (T_i S^-1), every other keyframe keeps its pose, and the edges between them (their
  // relative poses before the correction) spread the difference (Strasdat et al. 2010).
  const Sim3 correction = Sim3::FromMatrix(sim3).Inverse();
  const std::vector<int> segment = SegmentKeyframes();
  std::map<int, int> node_of_keyframe;
  PoseGraphProblem graph;
  std::vector<Sim3> before;
  for (int i : segment) {
    node_of_keyframe[i] = static_cast<int>(graph.cam_from_world.size());
    const Sim3 pose = Sim3::FromIsometry(keyframes_[static_cast<size_t>(i)].cam_from_segment);
    before.push_back(pose);
    const bool moved = std::find(neighbours.begin(), neighbours.end(), i) != neighbours.end();
    graph.cam_from_world.push_back(moved ? pose * correction : pose);
    graph.fixed.push_back(i == segment.front());
  }
  auto add_edge = [&](int a, int b, double weight) {
    const int na = node_of_keyframe.at(a), nb = node_of_keyframe.at(b);
    graph.edges.push_back(
        {na, nb, before[static_cast<size_t>(nb)] * before[static_cast<size_t>(na)].Inverse(),
         weight});
  };
  // The spanning chain, and covisibility edges (keyframes sharing 50 points or more).
  for (size_t j = 1; j < segment.size(); ++j) add_edge(segment[j - 1], segment[j], 1.0);
  for (int i : segment) {
    std::map<int, int> shared;
    for (int id : keyframes_[static_cast<size_t>(i)].point_of_keypoint) {
      if (id < 0 || !points_[static_cast<size_t>(id)].valid) continue;
      for (const WalkPoint::Observation& o : points_[static_cast<size_t>(id)].observations) {
        if (o.keyframe < i) ++shared[o.keyframe];
      }
    }
    for (const auto& [other, count] : shared) {
      if (count >= 50 && node_of_keyframe.count(other) && other != i - 1) add_edge(other, i, 1.0);
    }
  }
  // The loop edge: the keyframe as the loop keyframe's points place it.
  {
    const int nl = node_of_keyframe.at(loop), nk = node_of_keyframe.at(keyframe);
    graph.edges.push_back(
        {nl, nk,
         graph.cam_from_world[static_cast<size_t>(nk)] * before[static_cast<size_t>(nl)].Inverse(),
         1.0});
  }
  const PoseGraphSummary solved = OptimizePoseGraph(options_.pose_graph, &graph);
  if (!solved.ran) return false;
  const Eigen::Vector3d centre_before =
      keyframes_[static_cast<size_t>(keyframe)].cam_from_segment.inverse().translation();
  // Points follow their first observer's correction: X' = S_r'^-1 T_r X.
  for (WalkPoint& p : points_) {
    if (!p.valid || p.segment != segment_ || p.observations.empty()) continue;
    const auto it = node_of_keyframe.find(p.observations.front().keyframe);
    if (it == node_of_keyframe.end()) continue;
    const size_t n = static_cast<size_t>(it->second);
    p.position_in_segment = graph.cam_from_world[n].Inverse() * (before[n] * p.position_in_segment);
  }
  for (const auto& [i, n] : node_of_keyframe) {
    keyframes_[static_cast<size_t>(i)].cam_from_segment =
        graph.cam_from_world[static_cast<size_t>(n)].ToIsometry();
  }
  FusePoints(agreeing);
  if (!StartSegmentBundle(keyframe)) {
    // A long walk: the pose graph has spread the drift; the bundle adjustment stays local to
    // both ends of the loop (its CPU and memory grow with the segment).
    AdjustWindow(keyframe, summary);
    AdjustWindow(loop, summary);
  }
  ++loop_closures_;
  summary->loop_correction_m =
      (keyframes_[static_cast<size_t>(keyframe)].cam_from_segment.inverse().translation() -
       centre_before)
          .norm();
  summary->loop_s = SecondsSince(start);
  return true;
}

bool WalkMap::StartSegmentBundle(int keyframe) {
  const std::vector<int> segment = SegmentKeyframes();
  if (segment.size() < 3) return true;  // Nothing to adjust.
  if (static_cast<int>(segment.size()) > options_.global_bundle_max_keyframes) return false;
  SegmentBundleSnapshot snapshot;
  snapshot.segment = segment_;
  snapshot.loop_keyframe = keyframe;
  snapshot.keyframes = segment;
  LocalBundleProblem problem = BundleProblemOf(segment, segment_, 1, &snapshot.points);
  if (static_cast<int>(problem.observations.size()) > options_.global_bundle_max_observations) {
    return false;
  }
  segment_bundle_snapshot_ = std::move(snapshot);
  segment_bundle_.Start(options_.global_bundle, std::move(problem));
  return true;
}

void WalkMap::ApplySegmentBundle(WalkKeyframeSummary* summary) {
  BackgroundBundleResult result = segment_bundle_.Take();
  const SegmentBundleSnapshot& snapshot = segment_bundle_snapshot_;
  global_bundle_cpu_s_ += result.cpu_s;
  if (summary) {
    summary->global_bundle_applied = true;
    summary->global_bundle_cpu_s = result.cpu_s;
  }
  if (!result.summary.ran || snapshot.keyframes.empty()) return;
  // New poses: the adjusted ones; a keyframe added since keeps its pose relative to the
  // newest adjusted one, L: T_k' = T_k T_L^-1 T_L' (ORB-SLAM moves them down its spanning
  // tree the same way).
  std::map<int, Eigen::Isometry3d> corrected;
  for (size_t i = 0; i < snapshot.keyframes.size(); ++i) {
    corrected[snapshot.keyframes[i]] = result.problem.cam_from_world[i];
  }
  const int newest = snapshot.keyframes.back();
  const Eigen::Isometry3d old_from_new =
      keyframes_[static_cast<size_t>(newest)].cam_from_segment.inverse() * corrected.at(newest);
  for (size_t i = static_cast<size_t>(newest) + 1; i < keyframes_.size(); ++i) {
    const WalkKeyframe& k = keyframes_[i];
    if (k.registered && k.segment == snapshot.segment) {
      corrected[static_cast<int>(i)] = k.cam_from_segment * old_from_new;
    }
  }
  // Points: the adjusted positions; those made since follow their first observer,
  // X' = T_r'^-1 T_r X.
  std::map<int, Eigen::Vector3d> adjusted;
  for (size_t j = 0; j < snapshot.points.size(); ++j) {
    if (points_[static_cast<size_t>(snapshot.points[j])].valid) {
      adjusted[snapshot.points[j]] = result.problem.points_in_world[j];
    }
  }
  MoveKeyframes(corrected, adjusted);
  ++global_bundles_;
}

LocalBundleProblem WalkMap::BundleProblemOf(const std::vector<int>& keyframes, int segment,
                                            int min_observations, std::vector<int>* points) const {
  LocalBundleProblem problem;
  problem.k = K_;
  std::map<int, int> pose_of_keyframe;
  for (size_t i = 0; i < keyframes.size(); ++i) {
    pose_of_keyframe[keyframes[i]] = static_cast<int>(i);
    problem.cam_from_world.push_back(
        keyframes_[static_cast<size_t>(keyframes[i])].cam_from_segment);
    problem.pose_fixed.push_back(i < 2);
  }
  std::vector<LocalBundleProblem::Observation> seen;
  for (size_t id = 0; id < points_.size(); ++id) {
    const WalkPoint& p = points_[id];
    if (!p.valid || p.segment != segment) continue;
    const int index = static_cast<int>(problem.points_in_world.size());
    seen.clear();
    for (const WalkPoint::Observation& o : p.observations) {
      const auto it = pose_of_keyframe.find(o.keyframe);
      if (it != pose_of_keyframe.end())
        seen.push_back({it->second, index, Pixel(o.keyframe, o.keypoint)});
    }
    if (static_cast<int>(seen.size()) < min_observations || seen.empty()) continue;
    problem.observations.insert(problem.observations.end(), seen.begin(), seen.end());
    problem.points_in_world.push_back(p.position_in_segment);
    if (points) points->push_back(static_cast<int>(id));
  }
  return problem;
}

void WalkMap::MoveKeyframes(const std::map<int, Eigen::Isometry3d>& cam_from_segment,
                            const std::map<int, Eigen::Vector3d>& position_in_segment) {
  for (size_t id = 0; id < points_.size(); ++id) {
    WalkPoint& p = points_[id];
    if (const auto it = position_in_segment.find(static_cast<int>(id));
        it != position_in_segment.end()) {
      p.position_in_segment = it->second;
      continue;
    }
    if (!p.valid || p.observations.empty()) continue;
    const int first = p.observations.front().keyframe;
    const auto it = cam_from_segment.find(first);
    if (it == cam_from_segment.end()) continue;
    p.position_in_segment =
        it->second.inverse() *
        (keyframes_[static_cast<size_t>(first)].cam_from_segment * p.position_in_segment);
  }
  for (const auto& [i, pose] : cam_from_segment) {
    keyframes_[static_cast<size_t>(i)].cam_from_segment = pose;
  }
}

void WalkMap::Finish() {
  if (segment_bundle_.running()) ApplySegmentBundle(nullptr);
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

void WalkMap::AdjustWindow(int newest, WalkKeyframeSummary* summary) {
  const std::vector<int> adjusted = LocalKeyframes(newest, options_.window);
  if (adjusted.size() < 3) return;
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
