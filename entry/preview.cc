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
                      const Eigen::Matrix3d& K, int width, int height, std::string* error) {
  RenderCamera a;
  a.K = K;
  a.width = width;
  a.height = height;
  a.far_plane = FarPlaneFor(mesh, a.cam_from_world);
  a.near_plane = a.far_plane * 1e-4;
  const RenderCamera oblique_camera = ObliqueCamera(mesh, K, width, height);
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
  cv::Mat out;
  cv::hconcat(std::vector<cv::Mat>{from_a.rgb, oblique.rgb, shape.rgb}, out);
  return out;
}

}  // namespace mm
