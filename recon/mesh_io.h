#pragma once
// Mesh encoders. They produce bytes in memory; writing files (atomically) is the spool's job.
//
// Thread-safety: pure functions; reentrant.

#include <string>

#include "recon/mesh.h"

namespace mm {

/// Binary little-endian PLY: vertices (x y z, red green blue, s t) and faces (vertex_indices).
std::string EncodePly(const Mesh& mesh, const std::string& comment = "");

/// Wavefront OBJ with `v`, `vt` and `f v/vt` lines, using material `material_name` from
/// `mtl_file`.
std::string EncodeObj(const Mesh& mesh, const std::string& mtl_file,
                      const std::string& material_name = "keyframe_a");

/// The MTL that maps `material_name` to the texture image `texture_file`.
std::string EncodeMtl(const std::string& texture_file,
                      const std::string& material_name = "keyframe_a");

}  // namespace mm
