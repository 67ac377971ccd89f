#pragma once
// glTF 2.0 binary (GLB) encoder and decoder for the textured mesh, with tinygltf. One file:
// positions, texture coordinates, indices and the JPEG texture in the binary chunk, one
// material (base colour texture, KHR_materials_unlit: the texture is the photograph).
//
// Axes: glTF is y up and looks down -z; our mesh is in camera A's OpenCV frame (x right,
// y down, z forward). The GLB stores (x, -y, -z) so viewers show it upright; DecodeGlb
// converts back. The asset's extras say so, and that the mesh is up to scale.
//
// Thread-safety: pure functions; reentrant.

#include <filesystem>
#include <opencv2/core.hpp>
#include <span>
#include <string>

#include "recon/mesh.h"

namespace mm {

struct GlbInfo {
  std::string generator = "monomesh";
  /// Written to asset.extras.scale: a monocular reconstruction has no metric scale.
  std::string scale_note =
      "up to scale: a monocular pair fixes no metric scale; the baseline |t| = 1 is the unit";
  /// Written to asset.extras.frame: the frame the vertices are in.
  std::string frame_note =
      "camera A of the pair; stored as glTF axes (x, -y, -z) of OpenCV's camera frame";
  std::string node_name = "camera_a_frame";
};

/// One primitive of a GLB: a mesh with its own texture (a walk's keyframe meshes).
struct GlbPart {
  const Mesh* mesh = nullptr;
  const std::string* texture_jpeg = nullptr;  ///< May be null or empty: untextured.
  std::string name;                           ///< The material's and the image's name.
};

/// The GLB bytes. `texture_jpeg` is the encoded keyframe A (may be empty: untextured). The
/// mesh has at least one triangle (glTF accessors hold at least one element).
std::string EncodeGlb(const Mesh& mesh, const std::string& texture_jpeg, const GlbInfo& info = {});
/// One primitive and material per part (each part has at least one triangle).
std::string EncodeGlb(std::span<const GlbPart> parts, const GlbInfo& info = {});

/// The largest GLB read: far above a spool entry's mesh (a few MB), below a board's memory.
inline constexpr size_t kMaxGlbBytes = size_t{1} << 30;

/// Reads a GLB written by EncodeGlb (or any GLB with one triangle primitive using POSITION,
/// TEXCOORD_0 and indices, at least one vertex and a whole number of triangles) back into
/// camera-A coordinates. `texture_bgr` receives the decoded base colour image (empty when there
/// is none). Every accessor, buffer view and buffer is checked against the buffer's real size
/// with arithmetic that cannot wrap, values must be finite, the texture a PNG or JPEG of at most
/// kMaxImageSide px a side; a GLB is hostile input (`monomesh render` reads any file). Returns ""
/// or what went wrong, naming the glTF field (e.g. "POSITION: accessors[0].count ... overruns
/// bufferViews[0].byteLength 36").
[[nodiscard]] std::string DecodeGlb(const std::string& bytes, Mesh* mesh, cv::Mat* texture_bgr);

/// DecodeGlb of a file of at most kMaxGlbBytes (a regular file: not a FIFO or a device); the
/// message starts with the path. What `monomesh render` reads a mesh with.
[[nodiscard]] std::string ReadGlbFile(const std::filesystem::path& path, Mesh* mesh,
                                      cv::Mat* texture_bgr);

}  // namespace mm
