#include "entry/preview.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <vector>

#include "base/stats.h"

namespace mm {

RenderCamera ObliqueCamera(const Mesh& mesh, const Eigen::Matrix3d& K, int width, int height) {
  RenderCamera cam;
  cam.K = K;
  cam.width = width;
  cam.height = height;
  // Median point of the mesh (per axis, the lower median): robust to a few far vertices.
  Eigen::Vector3d centre(0, 0, 1);
  if (!mesh.vertices.empty()) {
    for (int k = 0; k < 3; ++k) {
      std::vector<double> c;
      for (const Eigen::Vector3f& v : mesh.vertices) c.push_back(v[k]);
      centre[k] = QuantileOf(std::move(c), 0.5);
    }
  }
  // Camera A's centre swung 40 degrees up about the centre (A's x axis; A's "up" is -y), and
  // 30 % further away so the whole mesh stays in view.
  const Eigen::Vector3d from_centre = -centre * 1.3;
  const Eigen::Vector3d eye =
      centre + Eigen::AngleAxisd(40.0 * M_PI / 180.0, Eigen::Vector3d::UnitX()) * from_centre;
  const Eigen::Vector3d z = (centre - eye).normalized();
  const Eigen::Vector3d x = Eigen::Vector3d::UnitY().cross(z).normalized();  // y = down.
  const Eigen::Vector3d y = z.cross(x);
  Eigen::Matrix3d world_from_cam;
  world_from_cam << x, y, z;
  cam.cam_from_world.linear() = world_from_cam.transpose();
  cam.cam_from_world.translation() = -world_from_cam.transpose() * eye;
  cam.far_plane = 10.0 * (eye - centre).norm() + 1.0;
  cam.near_plane = cam.far_plane * 1e-4;
  return cam;
}

cv::Mat RenderPreview(Renderer& renderer, const Mesh& mesh, const cv::Mat& texture_bgr,
                      const Eigen::Matrix3d& K, int width, int height, std::string* error) {
  RenderCamera a;
  a.K = K;
  a.width = width;
  a.height = height;
  a.far_plane = FarPlaneFor(mesh, a.cam_from_world);
  a.near_plane = a.far_plane * 1e-4;
  const RenderResult from_a = renderer.Render(mesh, texture_bgr, a);
  const RenderResult oblique =
      renderer.Render(mesh, texture_bgr, ObliqueCamera(mesh, K, width, height));
  if (!from_a.success || !oblique.success) {
    if (error != nullptr) {
      *error = from_a.success ? oblique.failure_reason : from_a.failure_reason;
    }
    return {};
  }
  cv::Mat out;
  cv::hconcat(from_a.rgb, oblique.rgb, out);
  return out;
}

}  // namespace mm
