#include "entry/mesh_io.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>
#include <sstream>

#include "recon/epipolar.h"

namespace mm {
namespace {

static_assert(std::endian::native == std::endian::little, "PLY writer assumes little endian");

template <typename T>
void Append(std::string* out, T value) {
  char bytes[sizeof(T)];
  std::memcpy(bytes, &value, sizeof(T));
  out->append(bytes, sizeof(T));
}

}  // namespace

std::string EncodePly(const Mesh& mesh, const std::string& comment) {
  const bool has_colors = mesh.colors.size() == mesh.vertices.size();
  const bool has_uvs = mesh.uvs.size() == mesh.vertices.size();
  std::ostringstream header;
  header << "ply\nformat binary_little_endian 1.0\n";
  if (!comment.empty()) header << "comment " << comment << "\n";
  header << "element vertex " << mesh.vertices.size() << "\n"
         << "property float x\nproperty float y\nproperty float z\n";
  if (has_colors) header << "property uchar red\nproperty uchar green\nproperty uchar blue\n";
  if (has_uvs) header << "property float s\nproperty float t\n";
  header << "element face " << mesh.triangles.size() << "\n"
         << "property list uchar int vertex_indices\nend_header\n";
  std::string out = header.str();
  out.reserve(out.size() + mesh.vertices.size() * 23 + mesh.triangles.size() * 13);
  for (size_t i = 0; i < mesh.vertices.size(); ++i) {
    for (int k = 0; k < 3; ++k) Append(&out, mesh.vertices[i][k]);
    if (has_colors) {
      for (int k = 0; k < 3; ++k) Append(&out, mesh.colors[i][k]);
    }
    if (has_uvs) {
      Append(&out, mesh.uvs[i].x());
      Append(&out, mesh.uvs[i].y());
    }
  }
  for (const Eigen::Vector3i& t : mesh.triangles) {
    Append(&out, static_cast<uint8_t>(3));
    for (int k = 0; k < 3; ++k) Append(&out, static_cast<int32_t>(t[k]));
  }
  return out;
}

std::string EncodeObj(const Mesh& mesh, const std::string& mtl_file,
                      const std::string& material_name) {
  std::ostringstream out;
  out.precision(7);
  out << "# monomesh two-view mesh; coordinates in camera A's frame, up to scale\n"
      << "mtllib " << mtl_file << "\n";
  for (const Eigen::Vector3f& v : mesh.vertices) {
    out << "v " << v.x() << " " << v.y() << " " << v.z() << "\n";
  }
  for (const Eigen::Vector2f& uv : mesh.uvs) out << "vt " << uv.x() << " " << uv.y() << "\n";
  out << "usemtl " << material_name << "\n";
  for (const Eigen::Vector3i& t : mesh.triangles) {
    out << "f";
    for (int k = 0; k < 3; ++k) out << " " << t[k] + 1 << "/" << t[k] + 1;
    out << "\n";
  }
  return out.str();
}

std::string EncodeMtl(const std::string& texture_file, const std::string& material_name) {
  std::ostringstream out;
  out << "newmtl " << material_name << "\n"
      << "Ka 1 1 1\nKd 1 1 1\nKs 0 0 0\nd 1\nillum 1\n"
      << "map_Kd " << texture_file << "\n";
  return out.str();
}

std::string EncodePointsPly(std::span<const Eigen::Vector3d> points,
                            std::span<const Eigen::Matrix<uint8_t, 3, 1>> colors_rgb,
                            const std::string& comment) {
  const bool has_colors = !colors_rgb.empty() && colors_rgb.size() == points.size();
  std::ostringstream header;
  header << "ply\nformat binary_little_endian 1.0\n";
  if (!comment.empty()) header << "comment " << comment << "\n";
  header << "element vertex " << points.size() << "\n"
         << "property float x\nproperty float y\nproperty float z\n";
  if (has_colors) header << "property uchar red\nproperty uchar green\nproperty uchar blue\n";
  header << "end_header\n";
  std::string out = header.str();
  out.reserve(out.size() + points.size() * 15);
  for (size_t i = 0; i < points.size(); ++i) {
    for (int k = 0; k < 3; ++k) Append(&out, static_cast<float>(points[i][k]));
    if (has_colors) {
      for (int k = 0; k < 3; ++k) Append(&out, colors_rgb[i][k]);
    }
  }
  return out;
}

ColmapText EncodeColmapModel(const ColmapModel& model) {
  ColmapText out;
  const Eigen::Matrix3d& K = model.K;
  // Per image, its observations in order: POINT2D_IDX is the position in this list.
  std::vector<std::vector<std::pair<Eigen::Vector2d, size_t>>> observations(model.images.size());
  std::vector<std::vector<std::pair<size_t, size_t>>> tracks(model.points.size());
  size_t total = 0;
  for (size_t p = 0; p < model.points.size(); ++p) {
    for (const ColmapModel::Observation& o : model.points[p].track) {
      if (o.image < 0 || o.image >= static_cast<int>(model.images.size())) continue;
      auto& list = observations[static_cast<size_t>(o.image)];
      tracks[p].emplace_back(static_cast<size_t>(o.image), list.size());
      list.emplace_back(o.pixel, p);
      ++total;
    }
  }
  {
    std::ostringstream c;
    c.precision(10);
    c << "# Camera list with one line of data per camera:\n"
      << "#   CAMERA_ID, MODEL, WIDTH, HEIGHT, PARAMS[]\n"
      << "# Number of cameras: 1\n";
    if (K(0, 1) != 0.0) c << "# monomesh: skew " << K(0, 1) << " dropped (PINHOLE)\n";
    c << "1 PINHOLE " << model.width << " " << model.height << " " << K(0, 0) << " " << K(1, 1)
      << " " << K(0, 2) + 0.5 << " " << K(1, 2) + 0.5 << "\n";
    out.cameras = c.str();
  }
  {
    std::ostringstream im;
    im.precision(12);
    im << "# Image list with two lines of data per image:\n"
       << "#   IMAGE_ID, QW, QX, QY, QZ, TX, TY, TZ, CAMERA_ID, NAME\n"
       << "#   POINTS2D[] as (X, Y, POINT3D_ID)\n"
       << "# Number of images: " << model.images.size() << ", mean observations per image: "
       << (model.images.empty() ? 0 : total / model.images.size()) << "\n";
    if (!model.scale_note.empty()) im << "# monomesh: " << model.scale_note << "\n";
    for (size_t i = 0; i < model.images.size(); ++i) {
      const ColmapModel::Image& image = model.images[i];
      const Eigen::Quaterniond q(image.cam_from_world.linear());
      const Eigen::Vector3d& t = image.cam_from_world.translation();
      im << i + 1 << " " << q.w() << " " << q.x() << " " << q.y() << " " << q.z() << " " << t.x()
         << " " << t.y() << " " << t.z() << " 1 " << image.name << "\n";
      for (size_t k = 0; k < observations[i].size(); ++k) {
        const auto& [pixel, point] = observations[i][k];
        im << (k ? " " : "") << pixel.x() + 0.5 << " " << pixel.y() + 0.5 << " " << point + 1;
      }
      im << "\n";
    }
    out.images = im.str();
  }
  {
    std::ostringstream pt;
    pt.precision(10);
    pt << "# 3D point list with one line of data per point:\n"
       << "#   POINT3D_ID, X, Y, Z, R, G, B, ERROR, TRACK[] as (IMAGE_ID, POINT2D_IDX)\n"
       << "# Number of points: " << model.points.size() << "\n";
    for (size_t p = 0; p < model.points.size(); ++p) {
      const ColmapModel::Point& point = model.points[p];
      // ERROR: the mean reprojection error over the track (pixels).
      double error = 0.0;
      int n = 0;
      for (const ColmapModel::Observation& o : point.track) {
        if (o.image < 0 || o.image >= static_cast<int>(model.images.size())) continue;
        const Eigen::Vector3d x =
            model.images[static_cast<size_t>(o.image)].cam_from_world * point.position;
        const Eigen::Vector3d h = K * x;
        error += (h.head<2>() / h.z() - o.pixel).norm();
        ++n;
      }
      error = n > 0 ? error / n : 0.0;
      const Eigen::Vector3d& x = point.position;
      pt << p + 1 << " " << x.x() << " " << x.y() << " " << x.z() << " " << int{point.rgb[0]} << " "
         << int{point.rgb[1]} << " " << int{point.rgb[2]} << " "
         << (std::isfinite(error) ? error : 0.0);
      for (const auto& [image, index] : tracks[p]) pt << " " << image + 1 << " " << index;
      pt << "\n";
    }
    out.points3d = pt.str();
  }
  return out;
}

ColmapText EncodeColmapText(const ColmapInput& in) {
  const size_t n = std::min({in.points_in_cam_a.size(), in.pixels_a.size(), in.pixels_b.size()});
  const bool has_colors = in.colors_rgb.size() >= n;
  ColmapModel model;
  model.width = in.width;
  model.height = in.height;
  model.K = in.K;
  model.scale_note = "up to scale (|t| = 1, the baseline, is the unit)";
  Eigen::Isometry3d cam_b_from_cam_a = Eigen::Isometry3d::Identity();
  cam_b_from_cam_a.linear() = in.rotation_b_from_a;
  cam_b_from_cam_a.translation() = in.translation_b_from_a;
  model.images = {{in.image_a_name, Eigen::Isometry3d::Identity()},
                  {in.image_b_name, cam_b_from_cam_a}};
  model.points.resize(n);
  for (size_t i = 0; i < n; ++i) {
    model.points[i].position = in.points_in_cam_a[i];
    if (has_colors) model.points[i].rgb = in.colors_rgb[i];
    model.points[i].track = {{0, in.pixels_a[i]}, {1, in.pixels_b[i]}};
  }
  return EncodeColmapModel(model);
}

std::vector<Eigen::Matrix<uint8_t, 3, 1>> SampleColors(const cv::Mat& image_bgr,
                                                       std::span<const Eigen::Vector2d> pixels) {
  std::vector<Eigen::Matrix<uint8_t, 3, 1>> out;
  out.reserve(pixels.size());
  for (const Eigen::Vector2d& px : pixels) {
    const int u = std::clamp(static_cast<int>(std::lround(px.x())), 0, image_bgr.cols - 1);
    const int v = std::clamp(static_cast<int>(std::lround(px.y())), 0, image_bgr.rows - 1);
    if (image_bgr.type() == CV_8UC3) {
      const cv::Vec3b& bgr = image_bgr.at<cv::Vec3b>(v, u);
      out.emplace_back(bgr[2], bgr[1], bgr[0]);
    } else {
      const uint8_t g = image_bgr.at<uint8_t>(v, u);
      out.emplace_back(g, g, g);
    }
  }
  return out;
}

}  // namespace mm
