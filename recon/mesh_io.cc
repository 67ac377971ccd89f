#include "recon/mesh_io.h"

#include <bit>
#include <cstring>
#include <sstream>

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

}  // namespace mm
