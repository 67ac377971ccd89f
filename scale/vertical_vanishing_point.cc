#include "scale/vertical_vanishing_point.h"

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <Eigen/LU>
#include <algorithm>
#include <cmath>
#include <numbers>
#include <opencv2/imgproc.hpp>
#include <random>
#include <vector>

namespace mm {
namespace {

struct Segment {
  Eigen::Vector2d p1, p2;
  Eigen::Vector3d plane_normal;  ///< Of the plane through the camera centre and the segment.
  double length = 0.0;
};

// The angle (radians) between the segment and the image line from its midpoint towards the
// vanishing point of direction `v` (Tardif 2009's consistency measure); works for a
// vanishing point at infinity too.
double ResidualRad(const Segment& s, const Eigen::Matrix3d& K, const Eigen::Vector3d& v) {
  const Eigen::Vector3d vp = K * v;
  const Eigen::Vector2d mid = 0.5 * (s.p1 + s.p2);
  const Eigen::Vector3d line = Eigen::Vector3d(mid.x(), mid.y(), 1.0).cross(vp);
  const Eigen::Vector2d towards(line.y(), -line.x());
  const Eigen::Vector2d along = s.p2 - s.p1;
  const double norms = towards.norm() * along.norm();
  if (!(norms > 0)) return std::numbers::pi / 2;
  return std::acos(std::clamp(std::abs(towards.dot(along)) / norms, 0.0, 1.0));
}

std::vector<int> Inliers(const std::vector<Segment>& segments, const Eigen::Matrix3d& K,
                         const Eigen::Vector3d& v, double sigma_px) {
  std::vector<int> inliers;
  for (size_t i = 0; i < segments.size(); ++i) {
    const Segment& s = segments[i];
    if (ResidualRad(s, K, v) < 2.0 * sigma_px / s.length) inliers.push_back(static_cast<int>(i));
  }
  return inliers;
}

double Length(const std::vector<Segment>& segments, const std::vector<int>& indices) {
  double sum = 0.0;
  for (int i : indices) sum += segments[static_cast<size_t>(i)].length;
  return sum;
}

// The direction closest to every inlier's interpretation plane (weighted by length), oriented
// like `up`.
Eigen::Vector3d Refit(const std::vector<Segment>& segments, const std::vector<int>& inliers,
                      const Eigen::Vector3d& up) {
  Eigen::Matrix3d scatter = Eigen::Matrix3d::Zero();
  for (int i : inliers) {
    const Segment& s = segments[static_cast<size_t>(i)];
    scatter += s.length * s.length * s.plane_normal * s.plane_normal.transpose();
  }
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eigen(scatter);
  Eigen::Vector3d v = eigen.eigenvectors().col(0);  // Smallest eigenvalue first.
  return v.dot(up) < 0 ? Eigen::Vector3d(-v) : v;
}

double AngleDeg(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return std::acos(std::clamp(a.normalized().dot(b.normalized()), -1.0, 1.0)) * 180.0 /
         std::numbers::pi;
}

// The direction most segments' lengths vote for (RANSAC over pairs of segments: a direction
// lies in both interpretation planes) among those `admissible` accepts, refitted to its inliers
// twice; zero when none. Oriented like `orient`.
template <typename Admissible>
Eigen::Vector3d DominantDirection(const std::vector<Segment>& segments, const Eigen::Matrix3d& K,
                                  const Eigen::Vector3d& orient,
                                  const VerticalVanishingOptions& options, std::mt19937& rng,
                                  Admissible admissible, std::vector<int>* inliers) {
  inliers->clear();
  if (segments.size() < 2) return Eigen::Vector3d::Zero();
  std::uniform_int_distribution<size_t> pick(0, segments.size() - 1);
  Eigen::Vector3d best = Eigen::Vector3d::Zero();
  double best_length = 0.0;
  for (int it = 0; it < options.iterations; ++it) {
    const size_t i = pick(rng), j = pick(rng);
    if (i == j) continue;
    Eigen::Vector3d v = segments[i].plane_normal.cross(segments[j].plane_normal);
    const double norm = v.norm();
    if (!(norm > 1e-6)) continue;  // One line seen twice.
    v /= norm;
    if (v.dot(orient) < 0) v = -v;
    if (!admissible(v)) continue;
    const double length = Length(segments, Inliers(segments, K, v, options.endpoint_sigma_px));
    if (length > best_length) {
      best_length = length;
      best = v;
    }
  }
  if (best_length == 0.0) return best;
  // Least squares on the inliers, twice (the inliers follow the refined direction).
  Eigen::Vector3d v = best;
  *inliers = Inliers(segments, K, v, options.endpoint_sigma_px);
  for (int round = 0; round < 2 && inliers->size() >= 2; ++round) {
    v = Refit(segments, *inliers, orient);
    *inliers = Inliers(segments, K, v, options.endpoint_sigma_px);
  }
  return v;
}

}  // namespace

std::string VerticalVanishingOptions::Check() const {
  if (!(max_deviation_deg > 0 && max_deviation_deg < 60))
    return "max_deviation_deg: not in (0, 60)";
  if (!(min_length_rel > 0 && min_length_rel < 1)) return "min_length_rel: not in (0, 1)";
  if (!(endpoint_sigma_px > 0)) return "endpoint_sigma_px: not positive";
  if (min_inliers < 3) return "min_inliers: at least 3";
  if (iterations < 1) return "iterations: at least 1";
  return {};
}

VerticalVanishingPoint EstimateVerticalVanishingPoint(const cv::Mat& gray, const Eigen::Matrix3d& K,
                                                      const Eigen::Vector3d& expected_up_in_cam,
                                                      const VerticalVanishingOptions& options) {
  VerticalVanishingPoint out;
  if (std::string problem = options.Check(); !problem.empty()) {
    out.why_not = "vertical vanishing point options: " + problem;
    return out;
  }
  if (gray.empty() || gray.type() != CV_8UC1) {
    out.why_not = "vertical vanishing point: no 8-bit grey image";
    return out;
  }
  const Eigen::Vector3d up = expected_up_in_cam.normalized();
  const double sin_max = std::sin(options.max_deviation_deg * std::numbers::pi / 180.0);
  const Eigen::Matrix3d K_inv = K.inverse();

  std::vector<cv::Vec4f> lines;
  cv::createLineSegmentDetector(cv::LSD_REFINE_STD)->detect(gray, lines);
  const double min_length = options.min_length_rel * gray.rows;
  std::vector<Segment> segments, others;  // Near vertical; the rest.
  for (const cv::Vec4f& l : lines) {
    Segment s;
    s.p1 = Eigen::Vector2d(l[0], l[1]);
    s.p2 = Eigen::Vector2d(l[2], l[3]);
    s.length = (s.p2 - s.p1).norm();
    if (s.length < min_length) continue;
    s.plane_normal = (K_inv * s.p1.homogeneous()).cross(K_inv * s.p2.homogeneous()).normalized();
    // A vertical segment's plane holds a direction within max_deviation_deg of up:
    // |n . up| <= sin(max).
    (std::abs(s.plane_normal.dot(up)) <= sin_max ? segments : others).push_back(s);
  }
  out.segments = static_cast<int>(segments.size());
  if (out.segments < options.min_inliers) {
    out.why_not = "too few near-vertical line segments (" + std::to_string(out.segments) + ")";
    return out;
  }

  std::mt19937 rng(options.seed);
  std::vector<int> inliers;
  Eigen::Vector3d v = DominantDirection(
      segments, K, up, options, rng,
      [&](const Eigen::Vector3d& d) { return AngleDeg(d, up) <= options.max_deviation_deg; },
      &inliers);
  if (v.isZero()) {
    out.why_not = "no vertical vanishing point within " +
                  std::to_string(static_cast<int>(options.max_deviation_deg)) +
                  " deg of the expected up";
    return out;
  }
  out.inliers = static_cast<int>(inliers.size());
  out.inlier_length_px = Length(segments, inliers);
  if (out.inliers < options.min_inliers) {
    out.why_not = "the vertical vanishing point has " + std::to_string(out.inliers) +
                  " segments (needs " + std::to_string(options.min_inliers) + ")";
    return out;
  }
  // The pitch is in the lines' convergence across the image: they must not all be in one
  // column (a tenth of the image's width apart at least).
  double min_x = gray.cols, max_x = 0.0;
  for (int i : inliers) {
    const Segment& s = segments[static_cast<size_t>(i)];
    const double x = 0.5 * (s.p1.x() + s.p2.x());
    min_x = std::min(min_x, x);
    max_x = std::max(max_x, x);
  }
  if (max_x - min_x < 0.1 * gray.cols) {
    out.why_not = "the vertical segments are all in one column of the image";
    return out;
  }
  double sum_sq = 0.0;
  for (int i : inliers) {
    const double r = ResidualRad(segments[static_cast<size_t>(i)], K, v) * 180.0 / std::numbers::pi;
    sum_sq += r * r;
  }
  out.rms_residual_deg = std::sqrt(sum_sq / out.inliers);
  out.deviation_deg = AngleDeg(v, up);
  if (out.deviation_deg > options.max_deviation_deg) {
    out.why_not = "the vertical vanishing point is " + std::to_string(out.deviation_deg) +
                  " deg from the expected up";
    return out;
  }
  // A level camera sees vertical lines nearly parallel, so their vanishing point fixes the
  // pitch least well. The dominant horizontal direction (a corridor's floor, ceiling and door
  // lines converging ahead) is perpendicular to up; its vanishing point is near the image
  // centre, where a degree of pitch moves it by f tan(1 deg) pixels: up is taken
  // perpendicular to it (Manhattan world), keeping the vertical lines' estimate otherwise.
  std::vector<int> horizontal_inliers;
  const Eigen::Vector3d h = DominantDirection(
      others, K, Eigen::Vector3d::UnitZ(), options, rng,
      [&](const Eigen::Vector3d& d) {
        return std::abs(d.dot(v)) <= sin_max && d.z() > std::cos(60.0 * std::numbers::pi / 180.0);
      },
      &horizontal_inliers);
  out.horizontal_inliers = static_cast<int>(horizontal_inliers.size());
  if (!h.isZero() && out.horizontal_inliers >= options.min_inliers) {
    out.horizontal_in_cam = h;
    v = (v - v.dot(h) * h).normalized();
  }
  out.deviation_deg = AngleDeg(v, up);
  out.up_in_cam = v;
  out.found = true;
  return out;
}

}  // namespace mm
