#include "scale/room_planes.h"

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <random>
#include <vector>

namespace mm {
namespace {

enum class Kind { kHorizontal, kWall };

struct Plane {
  Kind kind = Kind::kHorizontal;
  Eigen::Vector3d normal = Eigen::Vector3d::Zero();
  double offset = 0.0;  ///< normal . X + offset = 0.
  std::vector<int> points;
};

double Distance(const Eigen::Vector3d& normal, double offset, const Eigen::Vector3d& x) {
  return std::abs(normal.dot(x) + offset);
}

// The least-squares plane through the points, each weighted by 1 / depth^2.
void Refit(std::span<const Eigen::Vector3d> points, const std::vector<double>& depth,
           Plane* plane) {
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  double weight_sum = 0.0;
  for (int i : plane->points) {
    const double w = 1.0 / (depth[i] * depth[i]);
    centroid += w * points[i];
    weight_sum += w;
  }
  centroid /= weight_sum;
  Eigen::Matrix3d scatter = Eigen::Matrix3d::Zero();
  for (int i : plane->points) {
    const Eigen::Vector3d r = points[i] - centroid;
    scatter += r * r.transpose() / (depth[i] * depth[i]);
  }
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(scatter);
  Eigen::Vector3d n = eig.eigenvectors().col(0);
  if (n.dot(plane->normal) < 0) n = -n;
  plane->normal = n;
  plane->offset = -n.dot(centroid);
}

// Unit vectors spanning the plane perpendicular to `u`, continuous in u near `reference`.
void Basis(const Eigen::Vector3d& u, const Eigen::Vector3d& reference, Eigen::Vector3d* f1,
           Eigen::Vector3d* f2) {
  *f1 = (reference - reference.dot(u) * u).normalized();
  *f2 = u.cross(*f1);
}

// The joint model: up tilted from the nominal one by two angles, each horizontal plane's
// offset, each wall's azimuth about up and offset.
struct Model {
  Eigen::Vector3d nominal_up, e1, e2;  // e1, e2 perpendicular to nominal_up.
  std::vector<Kind> kinds;

  int Size() const {
    int n = 2;
    for (Kind k : kinds) n += k == Kind::kHorizontal ? 1 : 2;
    return n;
  }
  Eigen::Vector3d Up(const Eigen::VectorXd& p) const {
    return (nominal_up + p[0] * e1 + p[1] * e2).normalized();
  }
  // Every plane's normal and offset under parameters p.
  void Planes(const Eigen::VectorXd& p, std::vector<Eigen::Vector3d>* normals,
              std::vector<double>* offsets) const {
    const Eigen::Vector3d up = Up(p);
    Eigen::Vector3d f1, f2;
    Basis(up, e1, &f1, &f2);
    normals->clear();
    offsets->clear();
    int j = 2;
    for (Kind k : kinds) {
      if (k == Kind::kHorizontal) {
        normals->push_back(up);
        offsets->push_back(p[j++]);
      } else {
        const double azimuth = p[j++];
        normals->push_back(std::cos(azimuth) * f1 + std::sin(azimuth) * f2);
        offsets->push_back(p[j++]);
      }
    }
  }
};

// Gauss-Newton (with a little Levenberg damping) on the points' distances over their depths.
void JointFit(std::span<const Eigen::Vector3d> points, const std::vector<double>& depth,
              const Model& model, const std::vector<Plane>& planes, Eigen::VectorXd* params) {
  int residuals = 0;
  for (const Plane& plane : planes) residuals += static_cast<int>(plane.points.size());
  const auto evaluate = [&](const Eigen::VectorXd& p, Eigen::VectorXd* r) {
    std::vector<Eigen::Vector3d> normals;
    std::vector<double> offsets;
    model.Planes(p, &normals, &offsets);
    r->resize(residuals);
    int row = 0;
    for (size_t k = 0; k < planes.size(); ++k) {
      for (int i : planes[k].points)
        (*r)[row++] = (normals[k].dot(points[i]) + offsets[k]) / depth[i];
    }
  };
  const int n = model.Size();
  Eigen::VectorXd r, r_step;
  evaluate(*params, &r);
  double cost = r.squaredNorm();
  double lambda = 1e-6;
  for (int iteration = 0; iteration < 20; ++iteration) {
    Eigen::MatrixXd jacobian(residuals, n);
    for (int c = 0; c < n; ++c) {  // Central differences: the model is smooth.
      const double h = 1e-6 * std::max(1.0, std::abs((*params)[c]));
      Eigen::VectorXd plus = *params, minus = *params;
      plus[c] += h;
      minus[c] -= h;
      Eigen::VectorXd r_plus, r_minus;
      evaluate(plus, &r_plus);
      evaluate(minus, &r_minus);
      jacobian.col(c) = (r_plus - r_minus) / (2 * h);
    }
    const Eigen::MatrixXd normal_matrix = jacobian.transpose() * jacobian;
    const Eigen::VectorXd gradient = jacobian.transpose() * r;
    bool improved = false;
    for (int attempt = 0; attempt < 8 && !improved; ++attempt) {
      Eigen::MatrixXd damped = normal_matrix;
      damped.diagonal() *= 1.0 + lambda;
      const Eigen::VectorXd step = -damped.ldlt().solve(gradient);
      if (!step.allFinite()) break;
      const Eigen::VectorXd candidate = *params + step;
      evaluate(candidate, &r_step);
      const double candidate_cost = r_step.squaredNorm();
      if (candidate_cost < cost) {
        improved = true;
        const double relative_drop = (cost - candidate_cost) / std::max(cost, 1e-300);
        *params = candidate;
        r = r_step;
        cost = candidate_cost;
        lambda = std::max(lambda / 10, 1e-9);
        if (relative_drop < 1e-10) return;
      } else {
        lambda *= 10;
      }
    }
    if (!improved) return;
  }
}

}  // namespace

RoomPlanes FitRoomPlanes(std::span<const Eigen::Vector3d> points_in_cam,
                         const Eigen::Vector3d& nominal_up_in_cam,
                         const RoomPlanesOptions& options) {
  RoomPlanes out;
  const Eigen::Vector3d nominal_up = nominal_up_in_cam.normalized();
  std::vector<double> depth(points_in_cam.size(), 0.0);
  std::vector<int> usable;
  for (size_t i = 0; i < points_in_cam.size(); ++i) {
    const double d = points_in_cam[i].norm();
    if (std::isfinite(d) && d > 0) {
      depth[i] = d;
      usable.push_back(static_cast<int>(i));
    }
  }
  const int min_support = std::max(
      options.min_inliers,
      static_cast<int>(std::ceil(options.min_support_share * static_cast<double>(usable.size()))));
  if (static_cast<int>(usable.size()) < std::max(3, min_support)) {
    out.why_not = "too few points for the room's planes (" + std::to_string(usable.size()) + ")";
    return out;
  }
  const double sin_tilt = std::sin(options.max_tilt_deg * std::numbers::pi / 180.0);
  const double cos_tilt = std::cos(options.max_tilt_deg * std::numbers::pi / 180.0);
  const double band = options.inlier_distance_rel;

  // The planes one after another, each from the points no earlier plane took.
  std::mt19937 rng(options.seed);
  std::vector<Plane> planes;
  std::vector<int> remaining = usable;
  while (static_cast<int>(planes.size()) < options.max_planes &&
         static_cast<int>(remaining.size()) >= min_support) {
    std::uniform_int_distribution<size_t> pick(0, remaining.size() - 1);
    Plane best;
    size_t best_support = 0;
    for (int it = 0; it < options.iterations; ++it) {
      const Eigen::Vector3d& a = points_in_cam[remaining[pick(rng)]];
      const Eigen::Vector3d& b = points_in_cam[remaining[pick(rng)]];
      const Eigen::Vector3d& c = points_in_cam[remaining[pick(rng)]];
      Eigen::Vector3d n = (b - a).cross(c - a);
      const double norm = n.norm();
      if (!(norm > 0)) continue;
      n /= norm;
      if (n.dot(nominal_up) < 0) n = -n;
      const double along_up = n.dot(nominal_up);
      Kind kind;
      if (along_up > cos_tilt) {
        kind = Kind::kHorizontal;
      } else if (along_up < sin_tilt) {
        kind = Kind::kWall;
      } else {
        continue;
      }
      const double offset = -n.dot(a);
      size_t support = 0;
      for (int i : remaining)
        if (Distance(n, offset, points_in_cam[i]) < band * depth[i]) ++support;
      if (support > best_support) {
        best_support = support;
        best.kind = kind;
        best.normal = n;
        best.offset = offset;
      }
    }
    if (static_cast<int>(best_support) < min_support) break;
    // Its points, refitted once and taken again; the rest stay for the next plane.
    for (int round = 0; round < 2; ++round) {
      best.points.clear();
      for (int i : remaining)
        if (Distance(best.normal, best.offset, points_in_cam[i]) < band * depth[i])
          best.points.push_back(i);
      if (round == 0) Refit(points_in_cam, depth, &best);
    }
    if (static_cast<int>(best.points.size()) < min_support) break;
    std::vector<int> rest;
    size_t k = 0;
    for (int i : remaining) {
      while (k < best.points.size() && best.points[k] < i) ++k;
      if (k < best.points.size() && best.points[k] == i) continue;
      rest.push_back(i);
    }
    remaining.swap(rest);
    planes.push_back(std::move(best));
  }
  int horizontal = 0;
  for (const Plane& p : planes) horizontal += p.kind == Kind::kHorizontal ? 1 : 0;
  if (horizontal == 0) {
    out.why_not =
        "no floor in view (no horizontal plane with " + std::to_string(min_support) + " points)";
    return out;
  }

  // The joint fit: up from every plane at once.
  Model model;
  model.nominal_up = nominal_up;
  Basis(nominal_up,
        std::abs(nominal_up.x()) < 0.9 ? Eigen::Vector3d::UnitX() : Eigen::Vector3d::UnitZ(),
        &model.e1, &model.e2);
  for (const Plane& p : planes) model.kinds.push_back(p.kind);
  Eigen::VectorXd params = Eigen::VectorXd::Zero(model.Size());
  {
    Eigen::Vector3d f1, f2;
    Basis(nominal_up, model.e1, &f1, &f2);
    int j = 2;
    for (const Plane& p : planes) {
      if (p.kind == Kind::kHorizontal) {
        params[j++] = p.offset;  // Its normal was turned towards the nominal up.
      } else {
        params[j++] = std::atan2(p.normal.dot(f2), p.normal.dot(f1));
        params[j++] = p.offset;
      }
    }
  }
  std::vector<Eigen::Vector3d> normals;
  std::vector<double> offsets;
  for (int round = 0; round < options.rounds; ++round) {
    JointFit(points_in_cam, depth, model, planes, &params);
    // Each usable point to the nearest plane within its band.
    model.Planes(params, &normals, &offsets);
    for (Plane& p : planes) p.points.clear();
    for (int i : usable) {
      int nearest = -1;
      double nearest_distance = band * depth[i];
      for (size_t k = 0; k < planes.size(); ++k) {
        const double d = Distance(normals[k], offsets[k], points_in_cam[i]);
        if (d < nearest_distance) {
          nearest_distance = d;
          nearest = static_cast<int>(k);
        }
      }
      if (nearest >= 0) planes[nearest].points.push_back(i);
    }
    for (const Plane& p : planes) {
      if (p.points.empty()) {
        out.why_not = "a plane lost its points in the joint fit";
        return out;
      }
    }
  }
  JointFit(points_in_cam, depth, model, planes, &params);
  model.Planes(params, &normals, &offsets);
  const Eigen::Vector3d up = model.Up(params);
  out.up_in_cam = up;
  double sum_sq = 0.0;
  int count = 0;
  for (size_t k = 0; k < planes.size(); ++k) {
    for (int i : planes[k].points) {
      const double r = (normals[k].dot(points_in_cam[i]) + offsets[k]) / depth[i];
      sum_sq += r * r;
      ++count;
    }
    (planes[k].kind == Kind::kHorizontal ? out.horizontal_planes : out.walls) += 1;
  }
  out.rms_residual_rel = count > 0 ? std::sqrt(sum_sq / count) : 0.0;

  // The floor: below the camera (up . X = -offset < 0), not through it, the lowest of the
  // well supported ones.
  std::vector<double> below_depths;
  for (int i : usable)
    if (points_in_cam[i].dot(up) < 0) below_depths.push_back(depth[i]);
  if (below_depths.empty()) {
    out.why_not = "no points below the camera";
    return out;
  }
  std::nth_element(below_depths.begin(), below_depths.begin() + below_depths.size() / 2,
                   below_depths.end());
  const double min_distance = options.min_distance_rel * below_depths[below_depths.size() / 2];
  std::vector<HorizontalPlaneCandidate> below_camera;
  std::vector<int> plane_of_candidate;
  for (size_t k = 0; k < planes.size(); ++k) {
    if (planes[k].kind != Kind::kHorizontal || !(offsets[k] > min_distance)) continue;
    below_camera.push_back({offsets[k], planes[k].points.size()});
    plane_of_candidate.push_back(static_cast<int>(k));
  }
  // The planes are distinct (sequential RANSAC took each one's points away): no merging.
  const int chosen = ChooseFloorPlane(below_camera, options.lower_plane_support, 0.0);
  if (chosen < 0) {
    out.why_not = "no floor in view (no horizontal plane below the camera)";
    return out;
  }
  const int floor = plane_of_candidate[static_cast<size_t>(chosen)];
  // Nothing lies below a floor: points well below the lowest plane (walls reaching further
  // down) mean it is a table or box top and the floor is out of view.
  int below_floor = 0;
  for (int i : usable)
    if (up.dot(points_in_cam[i]) + offsets[floor] < -2 * band * depth[i]) ++below_floor;
  if (below_floor >= min_support) {
    out.why_not = "no floor in view (" + std::to_string(below_floor) +
                  " points lie below the lowest horizontal plane)";
    return out;
  }
  double floor_sq = 0.0;
  for (int i : planes[floor].points) {
    const double r = up.dot(points_in_cam[i]) + offsets[floor];
    floor_sq += r * r;
  }
  out.found = true;
  out.floor.found = true;
  out.floor.normal = up;
  out.floor.distance = offsets[floor];
  out.floor.inliers = static_cast<int>(planes[floor].points.size());
  out.floor.rms_residual = std::sqrt(floor_sq / static_cast<double>(planes[floor].points.size()));
  out.floor.normal_angle_deg =
      std::acos(std::clamp(up.dot(nominal_up), -1.0, 1.0)) * 180.0 / std::numbers::pi;
  return out;
}

}  // namespace mm
