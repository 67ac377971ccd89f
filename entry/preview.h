#pragma once
// preview.png of a spool entry: the mesh rendered from camera A, an oblique view of it, and the
// same oblique view shaded from the surface normals (the shape without the texture).
//
// Thread-safety: uses the given Renderer from the calling thread (see Renderer).

#include <Eigen/Core>
#include <opencv2/core.hpp>
#include <string>

#include "recon/mesh.h"
#include "render/renderer.h"

namespace mm {

/// The operator's preview: the mesh from camera A (identity pose, K), an oblique view from
/// above and behind A looking at the mesh's median point, textured, and the same view shaded
/// from the vertex normals. BGR8, 3 width x height.
/// Returns an empty image and sets *error on failure.
cv::Mat RenderPreview(Renderer& renderer, const Mesh& mesh, const cv::Mat& texture_bgr,
                      const Eigen::Matrix3d& K, int width, int height, std::string* error);

/// The mesh with vertex colours from Lambert shading of its area-weighted vertex normals, lit
/// from near `camera`'s viewpoint (for an untextured render of its shape).
Mesh ShadedByNormals(const Mesh& mesh, const RenderCamera& camera);

/// The oblique camera used by RenderPreview (exposed for tests).
RenderCamera ObliqueCamera(const Mesh& mesh, const Eigen::Matrix3d& K, int width, int height);

}  // namespace mm
