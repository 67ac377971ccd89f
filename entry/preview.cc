#include "entry/preview.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <limits>
#include <opencv2/imgproc.hpp>
#include <vector>

#include "base/stats.h"

namespace mm {
namespace {

// Draws the segment p-q (world points) as seen by `view`, clipped to its near plane.
void DrawSegment(const RenderCamera& view, const Eigen::Vector3d& p, const Eigen::Vector3d& q,
                 const cv::Scalar& color, int thickness, cv::Mat* image) {
  Eigen::Vector3d a = view.cam_from_world * p;
  Eigen::Vector3d b = view.cam_from_world * q;
  const double near = view.near_plane;
  if (a.z() < near && b.z() < near) return;
  if (a.z() < near) a = b + (a - b) * (b.z() - near) / (b.z() - a.z());
  if (b.z() < near) b = a + (b - a) * (a.z() - near) / (a.z() - b.z());
  const Eigen::Vector3d ua = view.K * a;
  const Eigen::Vector3d ub = view.K * b;
  // Endpoints far outside the image are clipped in floating point before cv::line's ints.
  cv::Point2d pa(ua.x() / ua.z(), ua.y() / ua.z());
  cv::Point2d pb(ub.x() / ub.z(), ub.y() / ub.z());
  const double limit = 4.0 * std::max(view.width, view.height);
  const auto inside = [&](const cv::Point2d& pt) {
    return std::abs(pt.x) < limit && std::abs(pt.y) < limit;
  };
  if (!inside(pa) || !inside(pb)) {
    // Shorten towards the inner end (or the midpoint) until both are within the limit.
    for (int i = 0; i < 40 && !(inside(pa) && inside(pb)); ++i) {
      if (!inside(pa)) pa = 0.5 * (pa + pb);
      if (!inside(pb)) pb = 0.5 * (pa + pb);
    }
    if (!inside(pa) || !inside(pb)) return;
  }
  cv::line(*image, cv::Point(cvRound(pa.x), cvRound(pa.y)), cv::Point(cvRound(pb.x), cvRound(pb.y)),
           color, thickness, cv::LINE_AA);
}

// A camera as a pyramid: its centre and its image's corners at `depth` in front of it.
void DrawFrustum(const RenderCamera& view, const Eigen::Matrix3d& K, int width, int height,
                 const Eigen::Isometry3d& cam_from_world, double depth, const cv::Scalar& color,
                 cv::Mat* image) {
  const Eigen::Isometry3d world_from_cam = cam_from_world.inverse();
  const Eigen::Matrix3d K_inv = K.inverse();
  const Eigen::Vector3d centre = world_from_cam.translation();
  std::vector<Eigen::Vector3d> corners;
  for (const auto& [u, v] : {std::pair{0.0, 0.0}, std::pair{1.0 * width, 0.0},
                             std::pair{1.0 * width, 1.0 * height}, std::pair{0.0, 1.0 * height}}) {
    const Eigen::Vector3d ray = K_inv * Eigen::Vector3d(u, v, 1.0);
    corners.push_back(world_from_cam * (ray * depth));
  }
  for (size_t i = 0; i < 4; ++i) {
    DrawSegment(view, centre, corners[i], color, 2, image);
    DrawSegment(view, corners[i], corners[(i + 1) % 4], color, 2, image);
  }
  // The image's top edge marked by a small triangle above it (which way is up).
  const Eigen::Vector3d top_mid = 0.5 * (corners[0] + corners[1]);
  const Eigen::Vector3d up = 0.25 * (corners[0] - corners[3]);
  DrawSegment(view, corners[0] + 0.3 * (corners[1] - corners[0]), top_mid + up, color, 2, image);
  DrawSegment(view, corners[1] + 0.3 * (corners[0] - corners[1]), top_mid + up, color, 2, image);
}

// A round grid spacing (1, 2 or 5 times a power of ten) giving about `lines` lines over `span`.
double GridStep(double span, double lines) {
  const double raw = span / lines;
  const double decade = std::pow(10.0, std::floor(std::log10(raw)));
  for (const double m : {1.0, 2.0, 5.0}) {
    if (m * decade >= raw) return m * decade;
  }
  return 10.0 * decade;
}

}  // namespace

void DrawPreviewCues(const Mesh& mesh, const Eigen::Matrix3d& K, const RenderCamera& view,
                     const cv::Mat& mesh_mask, const Eigen::Isometry3d* cam_b_from_cam_a,
                     cv::Mat* image) {
  if (mesh.vertices.empty()) return;
  std::vector<double> xs, ys, zs;
  for (const Eigen::Vector3f& v : mesh.vertices) {
    xs.push_back(v.x());
    ys.push_back(v.y());
    zs.push_back(v.z());
  }
  const double x_lo = QuantileOf(xs, 0.03), x_hi = QuantileOf(xs, 0.97);
  const double ground_y = QuantileOf(ys, 0.97);
  const double z_hi = QuantileOf(zs, 0.97);
  const double median_depth = QuantileOf(std::move(zs), 0.5);
  // The grid: from camera A to the far side of the mesh, as wide as the mesh, under it.
  if (z_hi > 0 && x_hi > x_lo) {
    const double step = GridStep(std::max(x_hi - x_lo, z_hi), 10.0);
    cv::Mat grid = cv::Mat::zeros(image->size(), image->type());
    const double x0 = std::floor(x_lo / step) * step, x1 = std::ceil(x_hi / step) * step;
    const double z1 = std::ceil(z_hi / step) * step;
    for (double x = x0; x <= x1 + 1e-9 * step; x += step) {
      DrawSegment(view, {x, ground_y, 0.0}, {x, ground_y, z1}, kPreviewGridColor, 1, &grid);
    }
    for (double z = 0.0; z <= z1 + 1e-9 * step; z += step) {
      DrawSegment(view, {x0, ground_y, z}, {x1, ground_y, z}, kPreviewGridColor, 1, &grid);
    }
    cv::Mat grid_mask;
    cv::cvtColor(grid, grid_mask, cv::COLOR_BGR2GRAY);
    grid.copyTo(*image, (grid_mask > 0) & (mesh_mask == 0));
  }
  // Frusta a tenth of the scene's median depth deep (at most half the baseline, so A's and
  // B's do not overlap).
  double depth = 0.1 * median_depth;
  if (cam_b_from_cam_a != nullptr) {
    depth = std::min(depth, 0.5 * cam_b_from_cam_a->translation().norm());
  }
  if (!(depth > 0)) return;
  DrawFrustum(view, K, view.width, view.height, Eigen::Isometry3d::Identity(), depth,
              kPreviewCameraAColor, image);
  if (cam_b_from_cam_a != nullptr) {
    DrawFrustum(view, K, view.width, view.height, *cam_b_from_cam_a, depth, kPreviewCameraBColor,
                image);
  }
}

RenderCamera ObliqueCamera(const Mesh& mesh, const Eigen::Matrix3d& K, int width, int height,
                           const Eigen::Isometry3d* cam_b_from_cam_a) {
  RenderCamera cam;
  cam.K = K;
  cam.width = width;
  cam.height = height;
  // Median point of the mesh (per axis, the lower median) and its 3-97 % box: robust to a few
  // far vertices.
  Eigen::Vector3d centre(0, 0, 1);
  Eigen::Vector3d lo = centre, hi = centre;
  if (!mesh.vertices.empty()) {
    for (int k = 0; k < 3; ++k) {
      std::vector<double> c;
      for (const Eigen::Vector3f& v : mesh.vertices) c.push_back(v[k]);
      lo[k] = QuantileOf(c, 0.1);
      hi[k] = QuantileOf(c, 0.9);
      centre[k] = QuantileOf(std::move(c), 0.5);
    }
  }
  // What must be in view: the mesh's box and the cameras' centres.
  std::vector<Eigen::Vector3d> keep{Eigen::Vector3d::Zero()};
  for (int corner = 0; corner < 8; ++corner) {
    keep.emplace_back((corner & 1) ? hi.x() : lo.x(), (corner & 2) ? hi.y() : lo.y(),
                      (corner & 4) ? hi.z() : lo.z());
  }
  if (cam_b_from_cam_a != nullptr) keep.push_back(cam_b_from_cam_a->inverse().translation());
  // Looking at the point between camera A and the mesh's median, from A's side swung 40
  // degrees up about A's x axis (A's "up" is -y), as far back as it takes to see all of them.
  const Eigen::Vector3d target = 0.6 * centre;
  const Eigen::Vector3d back =
      Eigen::AngleAxisd(30.0 * M_PI / 180.0, Eigen::Vector3d::UnitX()) * -centre.normalized();
  const Eigen::Vector3d z = -back;
  const Eigen::Vector3d x = Eigen::Vector3d::UnitY().cross(z).normalized();  // y = down.
  const Eigen::Vector3d y = z.cross(x);
  Eigen::Matrix3d world_from_cam;
  world_from_cam << x, y, z;
  const auto place = [&](double distance) {
    const Eigen::Vector3d eye = target + distance * back;
    cam.cam_from_world.linear() = world_from_cam.transpose();
    cam.cam_from_world.translation() = -world_from_cam.transpose() * eye;
  };
  const auto all_in_view = [&] {
    for (const Eigen::Vector3d& p : keep) {
      const Eigen::Vector3d c = cam.cam_from_world * p;
      if (c.z() <= 0) return false;
      const Eigen::Vector3d u = K * c;
      if (u.x() < 0.05 * width * u.z() || u.x() > 0.95 * width * u.z() ||
          u.y() < 0.05 * height * u.z() || u.y() > 0.95 * height * u.z()) {
        return false;
      }
    }
    return true;
  };
  double distance = 0.5 * centre.norm();
  place(distance);
  for (int i = 0; i < 30 && !all_in_view(); ++i) place(distance *= 1.15);
  cam.far_plane = 10.0 * (distance + (hi - lo).norm()) + 1.0;
  cam.near_plane = cam.far_plane * 1e-4;
  return cam;
}

Mesh ShadedByNormals(const Mesh& mesh, const RenderCamera& camera) {
  // Area-weighted vertex normals (the sum of the adjacent faces' cross products).
  std::vector<Eigen::Vector3f> normals(mesh.vertices.size(), Eigen::Vector3f::Zero());
  for (const Eigen::Vector3i& t : mesh.triangles) {
    const Eigen::Vector3f& p0 = mesh.vertices[static_cast<size_t>(t[0])];
    const Eigen::Vector3f n = (mesh.vertices[static_cast<size_t>(t[1])] - p0)
                                  .cross(mesh.vertices[static_cast<size_t>(t[2])] - p0);
    for (int k = 0; k < 3; ++k) normals[static_cast<size_t>(t[k])] += n;
  }
  // A headlight from the viewing camera, raised and to the left, two-sided Lambert with an
  // ambient term (every surface visible, its slant readable).
  const Eigen::Matrix3d world_from_cam = camera.cam_from_world.linear().transpose();
  const Eigen::Vector3f light =
      (world_from_cam * Eigen::Vector3d(-0.4, -0.6, -1.0).normalized()).cast<float>();
  Mesh shaded = mesh;
  shaded.colors.resize(mesh.vertices.size());
  for (size_t i = 0; i < normals.size(); ++i) {
    const float norm = normals[i].norm();
    const float lambert = norm > 0 ? std::abs(normals[i].dot(light)) / norm : 0.0f;
    const auto grey = static_cast<uint8_t>(std::clamp(40.0f + 200.0f * lambert, 0.0f, 255.0f));
    shaded.colors[i] = Eigen::Matrix<uint8_t, 3, 1>(grey, grey, grey);
  }
  return shaded;
}

cv::Mat RenderPreview(Renderer& renderer, const Mesh& mesh, const cv::Mat& texture_bgr,
                      const Eigen::Matrix3d& K, int width, int height, std::string* error,
                      const Eigen::Isometry3d* cam_b_from_cam_a) {
  RenderCamera a;
  a.K = K;
  a.width = width;
  a.height = height;
  a.far_plane = FarPlaneFor(mesh, a.cam_from_world);
  a.near_plane = a.far_plane * 1e-4;
  const RenderCamera oblique_camera = ObliqueCamera(mesh, K, width, height, cam_b_from_cam_a);
  const RenderResult from_a = renderer.Render(mesh, texture_bgr, a);
  const RenderResult oblique = renderer.Render(mesh, texture_bgr, oblique_camera);
  const RenderResult shape =
      renderer.Render(ShadedByNormals(mesh, oblique_camera), cv::Mat(), oblique_camera);
  for (const RenderResult* r : {&from_a, &oblique, &shape}) {
    if (!r->success) {
      if (error != nullptr) *error = r->failure_reason;
      return {};
    }
  }
  cv::Mat oblique_rgb = oblique.rgb.clone();
  cv::Mat shape_rgb = shape.rgb.clone();
  DrawPreviewCues(mesh, K, oblique_camera, oblique.mask, cam_b_from_cam_a, &oblique_rgb);
  DrawPreviewCues(mesh, K, oblique_camera, shape.mask, cam_b_from_cam_a, &shape_rgb);
  cv::Mat out;
  cv::hconcat(std::vector<cv::Mat>{from_a.rgb, oblique_rgb, shape_rgb}, out);
  return out;
}

Eigen::Vector3d UpFromCameras(std::span<const Eigen::Isometry3d> cam_from_world) {
  Eigen::Vector3d down = Eigen::Vector3d::Zero();
  for (const Eigen::Isometry3d& c : cam_from_world) down += c.linear().row(1).transpose();
  if (down.norm() < 1e-9) return -Eigen::Vector3d::UnitY();
  return -down.normalized();
}

namespace {

// A camera at `eye` looking along `forward`, its image's x axis along `right` (made
// orthogonal), focal length f.
RenderCamera LookingCamera(const Eigen::Vector3d& eye, const Eigen::Vector3d& forward,
                           const Eigen::Vector3d& right, double f, int width, int height) {
  const Eigen::Vector3d z = forward.normalized();
  const Eigen::Vector3d x = (right - right.dot(z) * z).normalized();
  const Eigen::Vector3d y = z.cross(x);
  Eigen::Matrix3d world_from_cam;
  world_from_cam << x, y, z;
  RenderCamera cam;
  cam.K << f, 0, 0.5 * (width - 1), 0, f, 0.5 * (height - 1), 0, 0, 1;
  cam.width = width;
  cam.height = height;
  cam.cam_from_world.linear() = world_from_cam.transpose();
  cam.cam_from_world.translation() = -world_from_cam.transpose() * eye;
  return cam;
}

}  // namespace

cv::Mat RenderWalkPreview(Renderer& renderer, const Mesh& mesh,
                          std::span<const Eigen::Isometry3d> cam_from_world,
                          const Eigen::Matrix3d& K, int width, int height, std::string* error) {
  const Eigen::Vector3d up = UpFromCameras(cam_from_world);
  std::vector<Eigen::Vector3d> centres;
  for (const Eigen::Isometry3d& c : cam_from_world) centres.push_back(c.inverse().translation());
  // The plan cut: everything above the highest camera goes.
  double cut = -std::numeric_limits<double>::infinity();
  for (const Eigen::Vector3d& c : centres) cut = std::max(cut, c.dot(up));
  Mesh below;
  below.vertices = mesh.vertices;
  below.colors = mesh.colors;
  for (const Eigen::Vector3i& t : mesh.triangles) {
    const Eigen::Vector3d centroid =
        ((mesh.vertices[static_cast<size_t>(t[0])] + mesh.vertices[static_cast<size_t>(t[1])] +
          mesh.vertices[static_cast<size_t>(t[2])]) /
         3.0f)
            .cast<double>();
    if (centroid.dot(up) <= cut) below.triangles.push_back(t);
  }
  // The extent: the cameras and the kept mesh's 5-95 % box.
  std::vector<Eigen::Vector3d> keep = centres;
  if (!below.triangles.empty()) {
    Eigen::Vector3d lo, hi;
    for (int k = 0; k < 3; ++k) {
      std::vector<double> c;
      for (const Eigen::Vector3i& t : below.triangles) {
        c.push_back(below.vertices[static_cast<size_t>(t[0])][k]);
      }
      lo[k] = QuantileOf(c, 0.05);
      hi[k] = QuantileOf(std::move(c), 0.95);
    }
    for (int corner = 0; corner < 8; ++corner) {
      keep.emplace_back((corner & 1) ? hi.x() : lo.x(), (corner & 2) ? hi.y() : lo.y(),
                        (corner & 4) ? hi.z() : lo.z());
    }
  }
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  for (const Eigen::Vector3d& p : keep) centre += p;
  centre /= std::max<size_t>(keep.size(), 1);
  double radius = 1e-3;
  for (const Eigen::Vector3d& p : keep) radius = std::max(radius, (p - centre).norm());
  // The walk's heading on the floor: the plan's x axis (first to last camera), up the page.
  Eigen::Vector3d heading = centres.size() >= 2 ? centres.back() - centres.front()
                                                : Eigen::Vector3d(Eigen::Vector3d::UnitZ());
  heading -= heading.dot(up) * up;
  if (heading.norm() < 1e-9) heading = up.unitOrthogonal();
  heading.normalize();
  const double distance = 4.0 * radius;
  const double f = 0.45 * std::min(width, height) * distance / radius;
  // Plan: from above, looking down, the heading up the page (image -y).
  RenderCamera plan =
      LookingCamera(centre + distance * up, -up, heading.cross(up), f, width, height);
  // The image's x axis is heading x up seen from above; flip if that puts heading down.
  if ((plan.cam_from_world.linear() * heading).y() > 0) {
    plan = LookingCamera(centre + distance * up, -up, -heading.cross(up), f, width, height);
  }
  // Oblique: from behind the start, raised 35 degrees.
  const Eigen::Vector3d back =
      (-heading * std::cos(35.0 * M_PI / 180) + up * std::sin(35.0 * M_PI / 180)).normalized();
  const RenderCamera oblique =
      LookingCamera(centre + distance * back, -back, heading.cross(up), f, width, height);
  std::vector<RenderCamera> views{plan, oblique};
  for (RenderCamera& v : views) {
    v.near_plane = 0.05 * radius;
    v.far_plane = distance + 4.0 * radius;
  }
  std::vector<cv::Mat> tiles;
  for (int shaded = 0; shaded < 2; ++shaded) {
    std::vector<cv::Mat> row;
    for (const RenderCamera& v : views) {
      const RenderResult r =
          below.triangles.empty()
              ? RenderResult{.success = true,
                             .failure_reason = {},
                             .rgb = cv::Mat(height, width, CV_8UC3, cv::Scalar::all(0)),
                             .depth = {},
                             .mask = {},
                             .covered_pixels = 0}
              : renderer.Render(shaded ? ShadedByNormals(below, v) : below, cv::Mat(), v);
      if (!r.success) {
        if (error != nullptr) *error = r.failure_reason;
        return {};
      }
      cv::Mat tile = r.rgb.clone();
      for (size_t i = 1; i < centres.size(); ++i) {
        DrawSegment(v, centres[i - 1], centres[i], kPreviewCameraBColor, 2, &tile);
      }
      if (!cam_from_world.empty()) {
        const double depth = 0.08 * radius;
        DrawFrustum(v, K, width, height, cam_from_world.front(), depth, kPreviewCameraAColor,
                    &tile);
        DrawFrustum(v, K, width, height, cam_from_world.back(), depth, kPreviewCameraBColor, &tile);
      }
      row.push_back(tile);
    }
    cv::Mat joined;
    cv::hconcat(row, joined);
    tiles.push_back(joined);
  }
  cv::Mat out;
  cv::vconcat(tiles, out);
  return out;
}

}  // namespace mm
