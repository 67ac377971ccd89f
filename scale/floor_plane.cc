#include "scale/floor_plane.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <random>
#include <vector>

namespace mm {
namespace {

std::vector<int> Inliers(std::span<const Eigen::Vector3d> points, const Eigen::Vector3d& n,
                         double d, double band) {
  std::vector<int> inliers;
  for (size_t i = 0; i < points.size(); ++i) {
    if (std::abs(n.dot(points[i]) + d) < band) inliers.push_back(static_cast<int>(i));
  }
  return inliers;
}

// The camera's height over the plane through the inliers with the normal held at `up`: the
// mean of their heights (least squares along the normal).
double MeanHeight(std::span<const Eigen::Vector3d> points, const std::vector<int>& inliers,
                  const Eigen::Vector3d& up) {
  double sum = 0.0;
  for (int i : inliers) sum -= up.dot(points[i]);
  return sum / static_cast<double>(inliers.size());
}

}  // namespace

int ChooseFloorPlane(std::span<const HorizontalPlaneCandidate> candidates,
                     double lower_plane_support, double same_plane_rel) {
  if (candidates.empty()) return -1;
  size_t best = 0;
  for (size_t k = 1; k < candidates.size(); ++k) {
    if (candidates[k].support > candidates[best].support) best = k;
  }
  size_t floor = best;
  for (size_t k = 0; k < candidates.size(); ++k) {
    const HorizontalPlaneCandidate& c = candidates[k];
    const HorizontalPlaneCandidate& f = candidates[floor];
    if (static_cast<double>(c.support) <
        lower_plane_support * static_cast<double>(candidates[best].support)) {
      continue;
    }
    if (c.distance > f.distance * (1.0 + same_plane_rel) ||
        (c.distance > f.distance * (1.0 - same_plane_rel) && c.support > f.support)) {
      floor = k;
    }
  }
  return static_cast<int>(floor);
}

FloorPlane FitFloorPlaneAlong(std::span<const Eigen::Vector3d> points_in_cam,
                              const Eigen::Vector3d& up_in_cam, const FloorPlaneOptions& options) {
  FloorPlane out;
  const int n = static_cast<int>(points_in_cam.size());
  if (n < std::max(1, options.min_inliers)) {
    out.why_not = "too few points for a floor (" + std::to_string(n) + ")";
    return out;
  }
  const Eigen::Vector3d up = up_in_cam.normalized();
  // The floor is below the camera: hypotheses from those points only.
  std::vector<int> below;
  for (int i = 0; i < n; ++i) {
    if (points_in_cam[i].dot(up) < 0) below.push_back(i);
  }
  if (static_cast<int>(below.size()) < std::max(1, options.min_inliers)) {
    out.why_not =
        "too few points below the camera for a floor (" + std::to_string(below.size()) + ")";
    return out;
  }
  // A floor closer to the camera than this is no floor (points at the camera centre: a
  // degenerate plane through them would make the scale unbounded).
  std::vector<double> depths;
  depths.reserve(below.size());
  for (int i : below) depths.push_back(points_in_cam[i].norm());
  std::nth_element(depths.begin(), depths.begin() + depths.size() / 2, depths.end());
  const double min_distance = options.min_distance_rel * depths[depths.size() / 2];

  // Hypotheses: one point each fixes the plane. Duplicates of one plane are many, which the
  // choice below does not mind.
  std::vector<HorizontalPlaneCandidate> candidates;
  std::mt19937 rng(options.seed);
  std::uniform_int_distribution<size_t> pick(0, below.size() - 1);
  for (int it = 0; it < options.iterations; ++it) {
    const double d = -up.dot(points_in_cam[below[pick(rng)]]);
    if (!(d > min_distance)) continue;  // The camera is not above it.
    const int support =
        static_cast<int>(Inliers(points_in_cam, up, d, options.inlier_distance_rel * d).size());
    if (support >= options.min_inliers) candidates.push_back({d, static_cast<size_t>(support)});
  }
  if (candidates.empty()) {
    out.why_not = "no horizontal plane below the camera with " +
                  std::to_string(options.min_inliers) + " points";
    return out;
  }
  // The best supported plane, or a lower one with enough support.
  const int floor =
      ChooseFloorPlane(candidates, options.lower_plane_support, options.inlier_distance_rel);
  // Two rounds of least squares on the inliers (the band follows the refined distance).
  double distance = candidates[static_cast<size_t>(floor)].distance;
  std::vector<int> inliers;
  for (int round = 0; round < 2; ++round) {
    inliers = Inliers(points_in_cam, up, distance, options.inlier_distance_rel * distance);
    if (inliers.empty()) break;
    const double refined = MeanHeight(points_in_cam, inliers, up);
    if (!(refined > min_distance)) break;
    distance = refined;
  }
  inliers = Inliers(points_in_cam, up, distance, options.inlier_distance_rel * distance);
  double sum_sq = 0.0;
  for (int i : inliers) {
    const double r = up.dot(points_in_cam[i]) + distance;
    sum_sq += r * r;
  }
  out.found = true;
  out.normal = up;
  out.distance = distance;
  out.inliers = static_cast<int>(inliers.size());
  out.rms_residual =
      inliers.empty() ? 0.0 : std::sqrt(sum_sq / static_cast<double>(inliers.size()));
  return out;
}

Eigen::Vector3d UpInCamera(double pitch_down_deg) {
  const double p = pitch_down_deg * std::numbers::pi / 180.0;
  return {0.0, -std::cos(p), -std::sin(p)};
}

}  // namespace mm
