#pragma once
// preview.png of a spool entry: the mesh rendered from camera A, an oblique view of it, and the
// same oblique view shaded from the surface normals (the shape without the texture). The two
// oblique views draw cameras A and B as frusta and a ground grid under the mesh as cues.
//
// Thread-safety: uses the given Renderer from the calling thread (see Renderer).

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <opencv2/core.hpp>
#include <span>
#include <string>

#include "recon/mesh.h"
#include "render/renderer.h"

namespace mm {

/// The operator's preview: the mesh from camera A (identity pose, K), an oblique view from
/// above and behind A (ObliqueCamera), textured, and the same view shaded from the vertex
/// normals. BGR8, 3 width x height. `cam_b_from_cam_a` (x_b = R x_a + t), when
/// given, places camera B's frustum beside A's.
/// Returns an empty image and sets *error on failure.
cv::Mat RenderPreview(Renderer& renderer, const Mesh& mesh, const cv::Mat& texture_bgr,
                      const Eigen::Matrix3d& K, int width, int height, std::string* error,
                      const Eigen::Isometry3d* cam_b_from_cam_a = nullptr);

/// Colours of the cues (BGR): camera A's frustum, camera B's, the ground grid.
inline const cv::Scalar kPreviewCameraAColor{0, 140, 255};
inline const cv::Scalar kPreviewCameraBColor{255, 200, 0};
inline const cv::Scalar kPreviewGridColor{60, 110, 60};

/// Draws the cues into `image`, a view through `view` of `mesh` whose coverage is `mesh_mask`
/// (CV_8UC1, 255 on the mesh): the grid on the plane below the mesh (A's frame, y down, at
/// the vertices' 97th percentile of y), only where the mesh is not, then the frusta of A and
/// (when given) B on top.
void DrawPreviewCues(const Mesh& mesh, const Eigen::Matrix3d& K, const RenderCamera& view,
                     const cv::Mat& mesh_mask, const Eigen::Isometry3d* cam_b_from_cam_a,
                     cv::Mat* image);

/// The mesh with vertex colours from Lambert shading of its area-weighted vertex normals, lit
/// from near `camera`'s viewpoint (for an untextured render of its shape).
Mesh ShadedByNormals(const Mesh& mesh, const RenderCamera& camera);

/// The oblique camera used by RenderPreview (exposed for tests): from above and behind camera
/// A, framing the mesh (its 3-97 % box) and the cameras' centres.
RenderCamera ObliqueCamera(const Mesh& mesh, const Eigen::Matrix3d& K, int width, int height,
                           const Eigen::Isometry3d* cam_b_from_cam_a = nullptr);

/// The cameras' up direction in the world: minus the mean of their y axes (OpenCV cameras,
/// y down; a robot's camera is about upright). Unit length; -y of the world when empty.
Eigen::Vector3d UpFromCameras(std::span<const Eigen::Isometry3d> cam_from_world);

/// A walk's preview: a top-down plan view beside an oblique view from behind the walk's start,
/// of `mesh` (vertex colours, world frame) cut above the highest camera (the ceiling would
/// hide the floor plan), with the keyframes' path and the first and last frusta drawn on both
/// and a second pair of the same views shaded by normals. BGR8, 2 width x 2 height.
/// Returns an empty image and sets *error on failure.
cv::Mat RenderWalkPreview(Renderer& renderer, const Mesh& mesh,
                          std::span<const Eigen::Isometry3d> cam_from_world,
                          const Eigen::Matrix3d& K, int width, int height, std::string* error);

}  // namespace mm
