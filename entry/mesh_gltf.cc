#include "entry/mesh_gltf.h"

#include <tiny_gltf.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <initializer_list>
#include <limits>
#include <opencv2/imgcodecs.hpp>
#include <optional>
#include <sstream>
#include <stdexcept>

#include "base/text_file.h"
#include "calib/camera_model.h"

namespace mm {
namespace {

// Appends raw bytes to the buffer, 4-byte aligned (glTF accessor alignment), and returns a
// new buffer view over them.
int AddView(tinygltf::Model* model, const void* data, size_t size, int target) {
  std::vector<unsigned char>& buf = model->buffers[0].data;
  while (buf.size() % 4 != 0) buf.push_back(0);
  tinygltf::BufferView view;
  view.buffer = 0;
  view.byteOffset = buf.size();
  view.byteLength = size;
  if (target != 0) view.target = target;
  const auto* bytes = static_cast<const unsigned char*>(data);
  buf.insert(buf.end(), bytes, bytes + size);
  model->bufferViews.push_back(view);
  return static_cast<int>(model->bufferViews.size()) - 1;
}

// Whether `count` elements of `elem` bytes, `stride` apart from byte `offset`, lie within `size`
// bytes. No product or sum is formed that could wrap (a count of 2^62 + 1 at stride 12 wraps to
// a small size).
bool SpanFits(uint64_t offset, uint64_t count, uint64_t stride, uint64_t elem, uint64_t size) {
  if (offset > size) return false;
  if (count == 0) return true;
  if (elem > size - offset) return false;
  return count - 1 <= (size - offset - elem) / stride;
}

// An accessor of the primitive read as `type` x `component`: element 0 and its stride, after
// checking the accessor, its buffer view and the view's buffer against the buffer's real size.
struct AccessorSpan {
  const unsigned char* data = nullptr;
  size_t stride = 0;
  size_t count = 0;
};

// "" and `*span`, or what is wrong, naming `what` (POSITION, indices ...) and the glTF field.
std::string ReadAccessor(const tinygltf::Model& model, int index, const std::string& what, int type,
                         std::initializer_list<int> components, AccessorSpan* span) {
  if (index < 0 || static_cast<size_t>(index) >= model.accessors.size()) {
    return what + ": accessor " + std::to_string(index) + " does not exist (" +
           std::to_string(model.accessors.size()) + " accessors)";
  }
  const tinygltf::Accessor& a = model.accessors[static_cast<size_t>(index)];
  const std::string field = what + ": accessors[" + std::to_string(index) + "].";
  if (a.type != type) return field + "type " + std::to_string(a.type) + " is not the expected one";
  if (std::find(components.begin(), components.end(), a.componentType) == components.end()) {
    return field + "componentType " + std::to_string(a.componentType) + " is not the expected one";
  }
  if (a.sparse.isSparse) return field + "sparse: sparse accessors are not read";
  if (a.bufferView < 0 || static_cast<size_t>(a.bufferView) >= model.bufferViews.size()) {
    return field + "bufferView " + std::to_string(a.bufferView) + " does not exist (" +
           std::to_string(model.bufferViews.size()) + " buffer views)";
  }
  const tinygltf::BufferView& v = model.bufferViews[static_cast<size_t>(a.bufferView)];
  const std::string view = what + ": bufferViews[" + std::to_string(a.bufferView) + "].";
  if (v.buffer < 0 || static_cast<size_t>(v.buffer) >= model.buffers.size()) {
    return view + "buffer " + std::to_string(v.buffer) + " does not exist (" +
           std::to_string(model.buffers.size()) + " buffers)";
  }
  const std::vector<unsigned char>& buf = model.buffers[static_cast<size_t>(v.buffer)].data;
  if (!SpanFits(v.byteOffset, 1, 1, v.byteLength, buf.size())) {
    return view + "byteOffset " + std::to_string(v.byteOffset) + " + byteLength " +
           std::to_string(v.byteLength) + " overrun buffers[" + std::to_string(v.buffer) + "] of " +
           std::to_string(buf.size()) + " bytes";
  }
  const size_t elem =
      static_cast<size_t>(
          tinygltf::GetComponentSizeInBytes(static_cast<uint32_t>(a.componentType))) *
      static_cast<size_t>(tinygltf::GetNumComponentsInType(static_cast<uint32_t>(a.type)));
  // glTF 2.0 3.6.2.4: byteStride is 4 to 252 and at least an element; 0 means packed.
  const size_t stride = v.byteStride != 0 ? v.byteStride : elem;
  if (stride < elem || stride > 252) {
    return view + "byteStride " + std::to_string(v.byteStride) + " is not " + std::to_string(elem) +
           " to 252 (the element's size to glTF's maximum)";
  }
  if (!SpanFits(a.byteOffset, a.count, stride, elem, v.byteLength)) {
    return field + "count " + std::to_string(a.count) + " (" + std::to_string(elem) +
           "-byte elements " + std::to_string(stride) + " apart from byteOffset " +
           std::to_string(a.byteOffset) + ") overruns bufferViews[" + std::to_string(a.bufferView) +
           "].byteLength " + std::to_string(v.byteLength);
  }
  span->data = buf.data() + v.byteOffset + a.byteOffset;
  span->stride = stride;
  span->count = a.count;
  return {};
}

// The width and height a PNG or JPEG header gives, without decoding the pixels; false for
// anything else (OpenCV would allocate the whole image a header claims before reading it).
bool ImageSize(const unsigned char* p, size_t n, int* width, int* height) {
  const auto be16 = [p](size_t i) { return (p[i] << 8) | p[i + 1]; };
  const auto be32 = [p](size_t i) {
    return (uint32_t{p[i]} << 24) | (uint32_t{p[i + 1]} << 16) | (uint32_t{p[i + 2]} << 8) |
           uint32_t{p[i + 3]};
  };
  static constexpr unsigned char kPng[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
  if (n >= 24 && std::memcmp(p, kPng, 8) == 0 && std::memcmp(p + 12, "IHDR", 4) == 0) {
    if (be32(16) > INT32_MAX || be32(20) > INT32_MAX) return false;
    *width = static_cast<int>(be32(16));
    *height = static_cast<int>(be32(20));
    return true;
  }
  if (n < 4 || p[0] != 0xff || p[1] != 0xd8) return false;
  // JPEG: the markers' segments up to the first start of frame (SOF0..SOF15 but DHT, JPG, DAC).
  for (size_t i = 2; i + 4 <= n;) {
    if (p[i] != 0xff) return false;
    const int marker = p[i + 1];
    if (marker == 0xff) {
      ++i;
      continue;
    }
    const size_t length = static_cast<size_t>(be16(i + 2));
    if (marker >= 0xc0 && marker <= 0xcf && marker != 0xc4 && marker != 0xc8 && marker != 0xcc) {
      if (i + 9 > n) return false;
      *height = be16(i + 5);
      *width = be16(i + 7);
      return true;
    }
    if (length < 2) return false;
    i += 2 + length;
  }
  return false;
}

// The largest texture read: a side of kMaxImageSide, 64 Mpx in all (a 16384 x 16384 colour
// texture would take 768 MB).
constexpr int64_t kMaxTexturePixels = int64_t{1} << 26;

// The primitive's base colour image, decoded, or nothing when it has none. Its buffer view is
// checked as an accessor's is, its header's size before any pixel is allocated.
std::string DecodeTexture(const tinygltf::Model& model, const tinygltf::Primitive& prim,
                          cv::Mat* texture_bgr) {
  if (prim.material < 0 || static_cast<size_t>(prim.material) >= model.materials.size()) return {};
  const int tex = model.materials[static_cast<size_t>(prim.material)]
                      .pbrMetallicRoughness.baseColorTexture.index;
  if (tex < 0 || static_cast<size_t>(tex) >= model.textures.size()) return {};
  const int src = model.textures[static_cast<size_t>(tex)].source;
  if (src < 0 || static_cast<size_t>(src) >= model.images.size()) return {};
  const tinygltf::Image& image = model.images[static_cast<size_t>(src)];
  const std::string field = "images[" + std::to_string(src) + "].";
  if (image.bufferView < 0 || static_cast<size_t>(image.bufferView) >= model.bufferViews.size()) {
    return field + "bufferView " + std::to_string(image.bufferView) +
           " does not exist (the texture must be inside the GLB)";
  }
  const tinygltf::BufferView& v = model.bufferViews[static_cast<size_t>(image.bufferView)];
  const std::string view = "bufferViews[" + std::to_string(image.bufferView) + "].";
  if (v.buffer < 0 || static_cast<size_t>(v.buffer) >= model.buffers.size()) {
    return view + "buffer " + std::to_string(v.buffer) + " does not exist";
  }
  const std::vector<unsigned char>& buf = model.buffers[static_cast<size_t>(v.buffer)].data;
  if (!SpanFits(v.byteOffset, 1, 1, v.byteLength, buf.size()) ||
      v.byteLength > static_cast<size_t>(std::numeric_limits<int>::max())) {
    return view + "byteOffset " + std::to_string(v.byteOffset) + " + byteLength " +
           std::to_string(v.byteLength) + " overrun buffers[" + std::to_string(v.buffer) + "] of " +
           std::to_string(buf.size()) + " bytes";
  }
  const unsigned char* bytes = buf.data() + v.byteOffset;
  int width = 0, height = 0;
  if (!ImageSize(bytes, v.byteLength, &width, &height)) {
    return field + "bufferView: not a PNG or JPEG image";
  }
  if (width < 1 || height < 1 || width > kMaxImageSide || height > kMaxImageSide ||
      int64_t{width} * height > kMaxTexturePixels) {
    return field + "bufferView: a " + std::to_string(width) + "x" + std::to_string(height) +
           " texture (at most " + std::to_string(kMaxImageSide) + " px a side, " +
           std::to_string(kMaxTexturePixels) + " px in all)";
  }
  const cv::Mat raw(1, static_cast<int>(v.byteLength), CV_8UC1, const_cast<unsigned char*>(bytes));
  try {
    *texture_bgr = cv::imdecode(raw, cv::IMREAD_COLOR);
  } catch (const cv::Exception&) {
    *texture_bgr = cv::Mat();
  }
  if (texture_bgr->empty()) return field + "bufferView: the image does not decode";
  return {};
}

}  // namespace

std::string EncodeGlb(const Mesh& mesh, const std::string& texture_jpeg, const GlbInfo& info) {
  const GlbPart part{.mesh = &mesh, .texture_jpeg = &texture_jpeg, .name = "keyframe_a"};
  return EncodeGlb(std::span<const GlbPart>(&part, 1), info);
}

std::string EncodeGlb(std::span<const GlbPart> parts, const GlbInfo& info) {
  tinygltf::Model model;
  model.asset.version = "2.0";
  model.asset.generator = info.generator;
  tinygltf::Value::Object extras;
  extras["scale"] = tinygltf::Value(info.scale_note);
  extras["frame"] = tinygltf::Value(info.frame_note);
  model.asset.extras = tinygltf::Value(extras);
  model.buffers.resize(1);
  model.extensionsUsed.push_back("KHR_materials_unlit");
  tinygltf::Sampler sampler;
  sampler.magFilter = TINYGLTF_TEXTURE_FILTER_LINEAR;
  sampler.minFilter = TINYGLTF_TEXTURE_FILTER_LINEAR;
  sampler.wrapS = TINYGLTF_TEXTURE_WRAP_CLAMP_TO_EDGE;
  sampler.wrapT = TINYGLTF_TEXTURE_WRAP_CLAMP_TO_EDGE;
  model.samplers.push_back(sampler);
  tinygltf::Mesh gmesh;
  gmesh.name = "monomesh";

  for (const GlbPart& part : parts) {
    const Mesh& mesh = *part.mesh;
    // Positions in glTF axes, with the bounds the spec requires.
    std::vector<float> positions;
    positions.reserve(mesh.vertices.size() * 3);
    std::vector<double> lo(3, std::numeric_limits<double>::max());
    std::vector<double> hi(3, std::numeric_limits<double>::lowest());
    for (const Eigen::Vector3f& v : mesh.vertices) {
      const float p[3] = {v.x(), -v.y(), -v.z()};
      for (int k = 0; k < 3; ++k) {
        positions.push_back(p[k]);
        lo[static_cast<size_t>(k)] =
            std::min(lo[static_cast<size_t>(k)], static_cast<double>(p[k]));
        hi[static_cast<size_t>(k)] =
            std::max(hi[static_cast<size_t>(k)], static_cast<double>(p[k]));
      }
    }
    // glTF texture coordinates have v down (origin at the image's top-left).
    std::vector<float> texcoords;
    const bool has_uvs = mesh.uvs.size() == mesh.vertices.size();
    if (has_uvs) {
      for (const Eigen::Vector2f& uv : mesh.uvs) {
        texcoords.push_back(uv.x());
        texcoords.push_back(1.0f - uv.y());
      }
    }
    std::vector<uint32_t> indices;
    for (const Eigen::Vector3i& t : mesh.triangles) {
      for (int k = 0; k < 3; ++k) indices.push_back(static_cast<uint32_t>(t[k]));
    }

    tinygltf::Primitive prim;
    prim.mode = TINYGLTF_MODE_TRIANGLES;
    {
      tinygltf::Accessor a;
      a.bufferView = AddView(&model, positions.data(), positions.size() * sizeof(float),
                             TINYGLTF_TARGET_ARRAY_BUFFER);
      a.componentType = TINYGLTF_COMPONENT_TYPE_FLOAT;
      a.type = TINYGLTF_TYPE_VEC3;
      a.count = mesh.vertices.size();
      if (!mesh.vertices.empty()) {
        a.minValues = lo;
        a.maxValues = hi;
      }
      model.accessors.push_back(a);
      prim.attributes["POSITION"] = static_cast<int>(model.accessors.size()) - 1;
    }
    if (has_uvs) {
      tinygltf::Accessor a;
      a.bufferView = AddView(&model, texcoords.data(), texcoords.size() * sizeof(float),
                             TINYGLTF_TARGET_ARRAY_BUFFER);
      a.componentType = TINYGLTF_COMPONENT_TYPE_FLOAT;
      a.type = TINYGLTF_TYPE_VEC2;
      a.count = mesh.uvs.size();
      model.accessors.push_back(a);
      prim.attributes["TEXCOORD_0"] = static_cast<int>(model.accessors.size()) - 1;
    }
    {
      tinygltf::Accessor a;
      a.bufferView = AddView(&model, indices.data(), indices.size() * sizeof(uint32_t),
                             TINYGLTF_TARGET_ELEMENT_ARRAY_BUFFER);
      a.componentType = TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT;
      a.type = TINYGLTF_TYPE_SCALAR;
      a.count = indices.size();
      model.accessors.push_back(a);
      prim.indices = static_cast<int>(model.accessors.size()) - 1;
    }

    tinygltf::Material material;
    material.name = part.name;
    material.doubleSided = true;
    material.pbrMetallicRoughness.metallicFactor = 0.0;
    material.pbrMetallicRoughness.roughnessFactor = 1.0;
    if (part.texture_jpeg != nullptr && !part.texture_jpeg->empty() && has_uvs) {
      tinygltf::Image image;
      image.name = part.name;
      image.mimeType = "image/jpeg";
      image.bufferView = AddView(&model, part.texture_jpeg->data(), part.texture_jpeg->size(), 0);
      model.images.push_back(image);
      tinygltf::Texture texture;
      texture.sampler = 0;
      texture.source = static_cast<int>(model.images.size()) - 1;
      model.textures.push_back(texture);
      material.pbrMetallicRoughness.baseColorTexture.index =
          static_cast<int>(model.textures.size()) - 1;
    }
    material.extensions["KHR_materials_unlit"] = tinygltf::Value(tinygltf::Value::Object());
    model.materials.push_back(material);
    prim.material = static_cast<int>(model.materials.size()) - 1;
    gmesh.primitives.push_back(prim);
  }
  model.meshes.push_back(gmesh);
  tinygltf::Node node;
  node.mesh = 0;
  node.name = info.node_name;
  model.nodes.push_back(node);
  tinygltf::Scene scene;
  scene.nodes.push_back(0);
  model.scenes.push_back(scene);
  model.defaultScene = 0;

  std::ostringstream out;
  tinygltf::TinyGLTF writer;
  writer.WriteGltfSceneToStream(&model, out, /*prettyPrint=*/false, /*writeBinary=*/true);
  return out.str();
}

std::string DecodeGlb(const std::string& bytes, Mesh* mesh, cv::Mat* texture_bgr) {
  *mesh = Mesh{};
  *texture_bgr = cv::Mat();
  tinygltf::TinyGLTF loader;
  // Images are decoded below with OpenCV, not by tinygltf.
  loader.SetImageLoader([](tinygltf::Image*, const int, std::string*, std::string*, int, int,
                           const unsigned char*, int, void*) { return true; },
                        nullptr);
  tinygltf::Model model;
  std::string err, warn;
  if (bytes.size() > kMaxGlbBytes) {
    return "larger than " + std::to_string(kMaxGlbBytes) + " bytes";
  }
  try {
    if (!loader.LoadBinaryFromMemory(&model, &err, &warn,
                                     reinterpret_cast<const unsigned char*>(bytes.data()),
                                     static_cast<unsigned int>(bytes.size()))) {
      return "not a readable GLB: " + err;
    }
  } catch (const std::exception& e) {
    // tinygltf reports most faults in `err` but throws on some (std::out_of_range from a
    // vector::at, found by glb_fuzz: a buffer of byteLength 0 read by its views).
    return std::string("not a readable GLB: ") + e.what();
  }
  if (model.meshes.empty() || model.meshes[0].primitives.empty()) return "no mesh in the GLB";
  const tinygltf::Primitive& prim = model.meshes[0].primitives[0];
  if (prim.mode != TINYGLTF_MODE_TRIANGLES) {
    return "meshes[0].primitives[0].mode " + std::to_string(prim.mode) +
           " is not a triangle list (4)";
  }
  auto pos_it = prim.attributes.find("POSITION");
  if (pos_it == prim.attributes.end()) return "meshes[0].primitives[0]: no POSITION attribute";
  AccessorSpan pos;
  if (std::string e = ReadAccessor(model, pos_it->second, "POSITION", TINYGLTF_TYPE_VEC3,
                                   {TINYGLTF_COMPONENT_TYPE_FLOAT}, &pos);
      !e.empty()) {
    return e;
  }
  // glTF 2.0 (accessor.count >= 1): a mesh has vertices, and a triangle list whole triangles.
  if (pos.count == 0) return "POSITION accessor has no vertices";
  mesh->vertices.reserve(pos.count);
  for (size_t i = 0; i < pos.count; ++i) {
    float p[3];
    std::memcpy(p, pos.data + i * pos.stride, sizeof(p));
    if (!std::isfinite(p[0]) || !std::isfinite(p[1]) || !std::isfinite(p[2])) {
      return "POSITION: vertex " + std::to_string(i) + " is not finite";
    }
    mesh->vertices.emplace_back(p[0], -p[1], -p[2]);
  }
  auto uv_it = prim.attributes.find("TEXCOORD_0");
  if (uv_it != prim.attributes.end()) {
    AccessorSpan uv;
    if (std::string e = ReadAccessor(model, uv_it->second, "TEXCOORD_0", TINYGLTF_TYPE_VEC2,
                                     {TINYGLTF_COMPONENT_TYPE_FLOAT}, &uv);
        !e.empty()) {
      return e;
    }
    if (uv.count != pos.count) {
      return "TEXCOORD_0: accessors[" + std::to_string(uv_it->second) + "].count " +
             std::to_string(uv.count) + " is not POSITION's " + std::to_string(pos.count);
    }
    mesh->uvs.reserve(uv.count);
    for (size_t i = 0; i < uv.count; ++i) {
      float t[2];
      std::memcpy(t, uv.data + i * uv.stride, sizeof(t));
      if (!std::isfinite(t[0]) || !std::isfinite(t[1])) {
        return "TEXCOORD_0: coordinate " + std::to_string(i) + " is not finite";
      }
      mesh->uvs.emplace_back(t[0], 1.0f - t[1]);
    }
  }
  AccessorSpan idx;
  if (std::string e = ReadAccessor(
          model, prim.indices, "indices", TINYGLTF_TYPE_SCALAR,
          {TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT, TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT,
           TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE},
          &idx);
      !e.empty()) {
    return e;
  }
  const int component = model.accessors[static_cast<size_t>(prim.indices)].componentType;
  if (idx.count == 0 || idx.count % 3 != 0) {
    return "indices: " + std::to_string(idx.count) +
           " is not a whole number of triangles (a triangle list needs 3 per triangle)";
  }
  if (pos.count > static_cast<size_t>(std::numeric_limits<int>::max())) {
    return "POSITION: " + std::to_string(pos.count) + " vertices are more than a mesh indexes";
  }
  mesh->triangles.reserve(idx.count / 3);
  const auto index_at = [&](size_t i) -> uint32_t {
    const unsigned char* at = idx.data + i * idx.stride;
    if (component == TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT) {
      uint32_t v;
      std::memcpy(&v, at, sizeof(v));
      return v;
    }
    if (component == TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT) {
      uint16_t v;
      std::memcpy(&v, at, sizeof(v));
      return v;
    }
    return *at;
  };
  for (size_t i = 0; i < idx.count; i += 3) {
    const uint32_t a = index_at(i), b = index_at(i + 1), c = index_at(i + 2);
    if (a >= pos.count || b >= pos.count || c >= pos.count) {
      return "indices: triangle " + std::to_string(i / 3) + " indexes a vertex beyond POSITION's " +
             std::to_string(pos.count);
    }
    mesh->triangles.emplace_back(static_cast<int>(a), static_cast<int>(b), static_cast<int>(c));
  }
  return DecodeTexture(model, prim, texture_bgr);
}

std::string ReadGlbFile(const std::filesystem::path& path, Mesh* mesh, cv::Mat* texture_bgr) {
  *mesh = Mesh{};
  *texture_bgr = cv::Mat();
  std::string error;
  const std::optional<std::string> bytes = ReadTextFile(path, kMaxGlbBytes, &error);
  if (!bytes) return error;
  if (std::string e = DecodeGlb(*bytes, mesh, texture_bgr); !e.empty()) {
    return path.string() + ": " + e;
  }
  return {};
}

}  // namespace mm
