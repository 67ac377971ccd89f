#include "entry/mesh_gltf.h"

#include <tiny_gltf.h>

#include <cstring>
#include <limits>
#include <opencv2/imgcodecs.hpp>
#include <sstream>
#include <stdexcept>

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

// Pointer to accessor element 0 and its stride, after checking it lies within its buffer.
const unsigned char* AccessorData(const tinygltf::Model& model, int index, int type, int component,
                                  size_t* stride, size_t* count) {
  if (index < 0 || index >= static_cast<int>(model.accessors.size())) return nullptr;
  const tinygltf::Accessor& a = model.accessors[static_cast<size_t>(index)];
  if (a.type != type || a.componentType != component || a.bufferView < 0 ||
      a.bufferView >= static_cast<int>(model.bufferViews.size())) {
    return nullptr;
  }
  const tinygltf::BufferView& v = model.bufferViews[static_cast<size_t>(a.bufferView)];
  if (v.buffer < 0 || v.buffer >= static_cast<int>(model.buffers.size())) return nullptr;
  const std::vector<unsigned char>& buf = model.buffers[static_cast<size_t>(v.buffer)].data;
  const size_t elem =
      static_cast<size_t>(tinygltf::GetComponentSizeInBytes(static_cast<uint32_t>(component))) *
      static_cast<size_t>(tinygltf::GetNumComponentsInType(static_cast<uint32_t>(type)));
  *stride = v.byteStride != 0 ? v.byteStride : elem;
  *count = a.count;
  const size_t begin = v.byteOffset + a.byteOffset;
  if (a.count > 0 && (begin + (a.count - 1) * *stride + elem > buf.size() ||
                      begin + (a.count - 1) * *stride + elem > v.byteOffset + v.byteLength)) {
    return nullptr;
  }
  return buf.data() + begin;
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
  if (prim.mode != TINYGLTF_MODE_TRIANGLES) return "primitive is not a triangle list";
  auto pos_it = prim.attributes.find("POSITION");
  if (pos_it == prim.attributes.end()) return "no POSITION";
  size_t stride = 0, count = 0;
  const unsigned char* pos = AccessorData(model, pos_it->second, TINYGLTF_TYPE_VEC3,
                                          TINYGLTF_COMPONENT_TYPE_FLOAT, &stride, &count);
  if (pos == nullptr) return "POSITION accessor unusable";
  // glTF 2.0 (accessor.count >= 1): a mesh has vertices, and a triangle list whole triangles.
  if (count == 0) return "POSITION accessor has no vertices";
  for (size_t i = 0; i < count; ++i) {
    float p[3];
    std::memcpy(p, pos + i * stride, sizeof(p));
    mesh->vertices.emplace_back(p[0], -p[1], -p[2]);
  }
  auto uv_it = prim.attributes.find("TEXCOORD_0");
  if (uv_it != prim.attributes.end()) {
    size_t uv_count = 0;
    const unsigned char* uv = AccessorData(model, uv_it->second, TINYGLTF_TYPE_VEC2,
                                           TINYGLTF_COMPONENT_TYPE_FLOAT, &stride, &uv_count);
    if (uv == nullptr || uv_count != count) return "TEXCOORD_0 accessor unusable";
    for (size_t i = 0; i < uv_count; ++i) {
      float t[2];
      std::memcpy(t, uv + i * stride, sizeof(t));
      mesh->uvs.emplace_back(t[0], 1.0f - t[1]);
    }
  }
  size_t index_count = 0;
  std::vector<uint32_t> indices;
  if (const unsigned char* idx =
          AccessorData(model, prim.indices, TINYGLTF_TYPE_SCALAR,
                       TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT, &stride, &index_count)) {
    for (size_t i = 0; i < index_count; ++i) {
      uint32_t v;
      std::memcpy(&v, idx + i * stride, sizeof(v));
      indices.push_back(v);
    }
  } else if (const unsigned char* idx16 =
                 AccessorData(model, prim.indices, TINYGLTF_TYPE_SCALAR,
                              TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT, &stride, &index_count)) {
    for (size_t i = 0; i < index_count; ++i) {
      uint16_t v;
      std::memcpy(&v, idx16 + i * stride, sizeof(v));
      indices.push_back(v);
    }
  } else {
    return "indices accessor unusable (uint32 or uint16 expected)";
  }
  if (indices.empty() || indices.size() % 3 != 0) {
    return "indices: " + std::to_string(indices.size()) +
           " is not a whole number of triangles (a triangle list needs 3 per triangle)";
  }
  for (size_t i = 0; i + 2 < indices.size(); i += 3) {
    if (indices[i] >= count || indices[i + 1] >= count || indices[i + 2] >= count) {
      return "index out of range";
    }
    mesh->triangles.emplace_back(indices[i], indices[i + 1], indices[i + 2]);
  }
  if (prim.material >= 0 && prim.material < static_cast<int>(model.materials.size())) {
    const int tex = model.materials[static_cast<size_t>(prim.material)]
                        .pbrMetallicRoughness.baseColorTexture.index;
    if (tex >= 0 && tex < static_cast<int>(model.textures.size())) {
      const int src = model.textures[static_cast<size_t>(tex)].source;
      if (src >= 0 && src < static_cast<int>(model.images.size())) {
        const tinygltf::Image& image = model.images[static_cast<size_t>(src)];
        if (image.bufferView >= 0 &&
            image.bufferView < static_cast<int>(model.bufferViews.size())) {
          const tinygltf::BufferView& v = model.bufferViews[static_cast<size_t>(image.bufferView)];
          const std::vector<unsigned char>& buf = model.buffers[static_cast<size_t>(v.buffer)].data;
          if (v.byteOffset + v.byteLength <= buf.size()) {
            const cv::Mat raw(1, static_cast<int>(v.byteLength), CV_8UC1,
                              const_cast<unsigned char*>(buf.data() + v.byteOffset));
            *texture_bgr = cv::imdecode(raw, cv::IMREAD_COLOR);
          }
        }
      }
    }
  }
  return {};
}

}  // namespace mm
