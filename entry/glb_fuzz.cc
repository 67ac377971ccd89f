// libFuzzer target for DecodeGlb, what `monomesh render` reads a mesh with (ReadGlbFile is the
// file read around it; the fuzz preset, scripts/fuzz.sh). Any bytes decode or return an error;
// a decoded mesh is finite, indexes only its own vertices, and survives the encoder: same
// vertices and triangles. Seeds hold the sizes that once got through: a POSITION count of
// 2^62 + 1 (the size wrapped), offsets past the buffer, a stride below the element, a texture
// header of 65535 x 65535 px.

#include <cstdint>
#include <cstdlib>
#include <string>

#include "entry/mesh_gltf.h"

namespace {

bool Finite(const mm::Mesh& mesh) {
  for (const auto& v : mesh.vertices) {
    if (!v.allFinite()) return false;
  }
  for (const auto& uv : mesh.uvs) {
    if (!uv.allFinite()) return false;
  }
  return true;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string bytes(reinterpret_cast<const char*>(data), size);
  mm::Mesh mesh;
  cv::Mat texture;
  if (!mm::DecodeGlb(bytes, &mesh, &texture).empty()) return 0;
  const int n = static_cast<int>(mesh.vertices.size());
  for (const auto& t : mesh.triangles) {
    if ((t.array() < 0).any() || (t.array() >= n).any()) std::abort();
  }
  if (!mesh.uvs.empty() && mesh.uvs.size() != mesh.vertices.size()) std::abort();
  if (!Finite(mesh)) std::abort();
  if (mesh.uvs.size() != mesh.vertices.size()) return 0;
  mm::Mesh again;
  cv::Mat no_texture;
  if (!mm::DecodeGlb(mm::EncodeGlb(mesh, ""), &again, &no_texture).empty()) std::abort();
  if (again.vertices != mesh.vertices || again.triangles != mesh.triangles) std::abort();
  return 0;
}
