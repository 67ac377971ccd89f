#include "scale/floor_plane.h"

#include <Eigen/Geometry>
#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

namespace mm {
namespace {

constexpr double kPi = 3.14159265358979323846;

struct Plane {
  Eigen::Vector3d normal;
  double distance = 0.0;
  int support = 0;
};

// The plane through the inliers by least squares, oriented like `up`.
bool Refit(std::span<const Eigen::Vector3d> points, const std::vector<int>& inliers,
           const Eigen::Vector3d& up, Plane* plane) {
  if (inliers.size() < 3) return false;
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  for (int i : inliers) centroid += points[i];
  centroid /= static_cast<double>(inliers.size());
  Eigen::MatrixXd centred(inliers.size(), 3);
  for (size_t k = 0; k < inliers.size(); ++k)
    centred.row(k) = (points[inliers[k]] - centroid).transpose();
  const Eigen::JacobiSVD<Eigen::MatrixXd> svd(centred, Eigen::ComputeThinV);
  Eigen::Vector3d n = svd.matrixV().col(2);
  if (n.dot(up) < 0) n = -n;
  plane->normal = n;
  plane->distance = -n.dot(centroid);
  return true;
}

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
bool RefitDistance(std::span<const Eigen::Vector3d> points, const std::vector<int>& inliers,
                   const Eigen::Vector3d& up, Plane* plane) {
  if (inliers.empty()) return false;
  double sum = 0.0;
  for (int i : inliers) sum -= up.dot(points[i]);
  plane->normal = up;
  plane->distance = sum / static_cast<double>(inliers.size());
  return true;
}

FloorPlane Fit(std::span<const Eigen::Vector3d> points_in_cam, const Eigen::Vector3d& up_in_cam,
               const FloorPlaneOptions& options, bool normal_known);

}  // namespace

FloorPlane FitFloorPlane(std::span<const Eigen::Vector3d> points_in_cam,
                         const Eigen::Vector3d& up_in_cam, const FloorPlaneOptions& options) {
  return Fit(points_in_cam, up_in_cam, options, /*normal_known=*/false);
}

FloorPlane FitFloorPlaneAlong(std::span<const Eigen::Vector3d> points_in_cam,
                              const Eigen::Vector3d& up_in_cam, const FloorPlaneOptions& options) {
  return Fit(points_in_cam, up_in_cam, options, /*normal_known=*/true);
}

Eigen::Vector3d UpInCamera(double pitch_down_deg) {
  const double p = pitch_down_deg * kPi / 180.0;
  return {0.0, -std::cos(p), -std::sin(p)};
}

namespace {

FloorPlane Fit(std::span<const Eigen::Vector3d> points_in_cam, const Eigen::Vector3d& up_in_cam,
               const FloorPlaneOptions& options, bool normal_known) {
  FloorPlane out;
  const int n = static_cast<int>(points_in_cam.size());
  if (n < std::max(3, options.min_inliers)) {
    out.why_not = "too few points for a floor (" + std::to_string(n) + ")";
    return out;
  }
  const Eigen::Vector3d up = up_in_cam.normalized();
  const double cos_max = std::cos(options.max_normal_deg * kPi / 180.0);
  // The floor is below the camera: samples from those points only.
  std::vector<int> below;
  for (int i = 0; i < n; ++i) {
    if (points_in_cam[i].dot(up) < 0) below.push_back(i);
  }
  if (static_cast<int>(below.size()) < std::max(3, options.min_inliers)) {
    out.why_not =
        "too few points below the camera for a floor (" + std::to_string(below.size()) + ")";
    return out;
  }
  std::mt19937 rng(options.seed);
  std::uniform_int_distribution<size_t> pick(0, below.size() - 1);
  // Hypotheses that are horizontal, below the camera and supported; duplicates of one plane
  // are many, which the selection below does not mind.
  std::vector<Plane> candidates;
  // A floor closer to the camera than this is no floor (points at the camera centre: a
  // degenerate plane through them would make the scale unbounded).
  std::vector<double> depths;
  depths.reserve(below.size());
  for (int i : below) depths.push_back(points_in_cam[i].norm());
  std::nth_element(depths.begin(), depths.begin() + depths.size() / 2, depths.end());
  const double min_distance = options.min_distance_rel * depths[depths.size() / 2];
  for (int it = 0; it < options.iterations; ++it) {
    Eigen::Vector3d normal = up;  // Known: one point fixes the plane.
    const int i = below[pick(rng)];
    if (!normal_known) {
      const int j = below[pick(rng)], k = below[pick(rng)];
      if (i == j || j == k || i == k) continue;
      normal = (points_in_cam[j] - points_in_cam[i]).cross(points_in_cam[k] - points_in_cam[i]);
      const double norm = normal.norm();
      if (!(norm > 0)) continue;
      normal /= norm;
      if (normal.dot(up) < 0) normal = -normal;
      if (normal.dot(up) < cos_max) continue;
    }
    const double d = -normal.dot(points_in_cam[i]);
    if (!(d > min_distance)) continue;  // The camera is not above it.
    const int support =
        static_cast<int>(Inliers(points_in_cam, normal, d, options.inlier_distance_rel * d).size());
    if (support >= options.min_inliers) candidates.push_back({normal, d, support});
  }
  if (candidates.empty()) {
    out.why_not = "no horizontal plane below the camera with " +
                  std::to_string(options.min_inliers) + " points";
    return out;
  }
  int best_support = 0;
  for (const Plane& p : candidates) best_support = std::max(best_support, p.support);
  // The best supported plane, or a lower one parallel to it with enough support.
  const Plane* best = nullptr;
  for (const Plane& p : candidates) {
    if (best == nullptr || p.support > best->support) best = &p;
  }
  const double cos_parallel = std::cos(options.parallel_deg * kPi / 180.0);
  const Plane* floor = best;
  for (const Plane& p : candidates) {
    if (p.support < options.lower_plane_support * best_support) continue;
    if (p.normal.dot(best->normal) < cos_parallel) continue;
    if (p.distance > floor->distance * (1.0 + options.inlier_distance_rel) ||
        (p.distance > floor->distance * (1.0 - options.inlier_distance_rel) &&
         p.support > floor->support)) {
      floor = &p;
    }
  }
  // Two rounds of least squares on the inliers (the band follows the refined distance).
  Plane plane = *floor;
  std::vector<int> inliers;
  for (int round = 0; round < 2; ++round) {
    inliers = Inliers(points_in_cam, plane.normal, plane.distance,
                      options.inlier_distance_rel * plane.distance);
    Plane refined;
    const bool refitted = normal_known ? RefitDistance(points_in_cam, inliers, up, &refined)
                                       : Refit(points_in_cam, inliers, up, &refined);
    if (!refitted || !(refined.distance > min_distance) ||
        refined.normal.dot(up) < cos_max) {
      break;
    }
    plane.normal = refined.normal;
    plane.distance = refined.distance;
  }
  inliers = Inliers(points_in_cam, plane.normal, plane.distance,
                    options.inlier_distance_rel * plane.distance);
  double sum_sq = 0.0;
  for (int i : inliers) {
    const double r = plane.normal.dot(points_in_cam[i]) + plane.distance;
    sum_sq += r * r;
  }
  out.found = true;
  out.normal = plane.normal;
  out.distance = plane.distance;
  out.inliers = static_cast<int>(inliers.size());
  out.rms_residual =
      inliers.empty() ? 0.0 : std::sqrt(sum_sq / static_cast<double>(inliers.size()));
  out.normal_angle_deg = std::acos(std::clamp(plane.normal.dot(up), -1.0, 1.0)) * 180.0 / kPi;
  return out;
}

}  // namespace

}  // namespace mm
