#pragma once
// Offscreen rendering of a textured mesh with EGL + OpenGL ES 3.0, headless: Mesa's
// surfaceless platform (EGL_PLATFORM_SURFACELESS_MESA, EGL_KHR_surfaceless_context), a
// framebuffer object (RGBA8 colour, RGBA8 packed linear depth, DEPTH24 z-buffer), shaders in
// "#version 300 es" so they also run on a Raspberry Pi's GPU (GLES 3.1). Runs on llvmpipe.
//
// Camera: OpenCV convention (x right, y down, z forward; pixel centres at integer
// coordinates), K with skew, pose cam_from_world, image size. The GL projection maps pixel
// (u, v) to the centre of framebuffer pixel (u, v) with row 0 at the top, and z in
// [near, far] to the depth range; depth is written out linear, in scene units.
//
// Thread-safety: a Renderer owns an EGL context current on the thread that created it; use
// it from that thread only.

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <memory>
#include <opencv2/core.hpp>
#include <string>

#include "recon/mesh.h"

namespace mm {

struct RenderCamera {
  Eigen::Matrix3d K = Eigen::Matrix3d::Identity();
  Eigen::Isometry3d cam_from_world = Eigen::Isometry3d::Identity();
  int width = 0;
  int height = 0;
  double near_plane = 0.01;  ///< Scene units.
  double far_plane = 1000.0;
  [[nodiscard]] std::string Check() const;
};

struct RenderResult {
  bool success = false;
  std::string failure_reason;
  cv::Mat rgb;    ///< CV_8UC3 (BGR, OpenCV order), background black.
  cv::Mat depth;  ///< CV_32FC1 z in the camera frame (scene units); 0 where nothing is drawn.
  cv::Mat mask;   ///< CV_8UC1, 255 where the mesh covers the pixel.
  int covered_pixels = 0;
};

struct UploadOptions {
  /// Trilinear filtering over a mipmap chain (glGenerateMipmap, GLES 3.0) instead of bilinear:
  /// textures seen minified (a corridor's far floor) do not alias. Off: the spool's previews
  /// sample their keyframe texture about 1:1.
  bool mipmaps = false;
};

class Renderer {
 public:
  /// Creates the EGL display and context. On failure, ok() is false and error() says why.
  Renderer();
  ~Renderer();
  Renderer(const Renderer&) = delete;
  Renderer& operator=(const Renderer&) = delete;

  [[nodiscard]] bool ok() const;
  [[nodiscard]] const std::string& error() const;
  /// GL_RENDERER, for logs (e.g. "llvmpipe (LLVM 15.0.6, 256 bits)").
  [[nodiscard]] std::string gl_renderer() const;

  /// Draws `mesh` (vertices in world coordinates, UVs into `texture_bgr`, v up) from `camera`.
  /// An empty texture draws the vertex colours (or grey). Upload + Draw + Release in one call.
  RenderResult Render(const Mesh& mesh, const cv::Mat& texture_bgr, const RenderCamera& camera);

  /// Uploads a mesh and its texture once (vertex/index buffers, texture) for drawing from many
  /// cameras with Draw(), e.g. a synthetic sequence. Returns a handle >= 0, or -1 with `error`
  /// set. The mesh lives until Release() or the renderer's end.
  int Upload(const Mesh& mesh, const cv::Mat& texture_bgr, const UploadOptions& options,
             std::string* error);
  /// Draws an uploaded mesh from `camera` (the framebuffer is kept between draws of one size).
  RenderResult Draw(int mesh_id, const RenderCamera& camera);
  /// Frees an uploaded mesh (unknown handles are ignored).
  void Release(int mesh_id);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// Initializes the process's EGL display and loads the GL driver, which a process does once
/// (its display is never terminated): with Mesa's llvmpipe that first Renderer takes about
/// 0.15-0.2 s, each later one about 5 ms. A long-running program calls this at start so that
/// its first render does not pay for it. Returns the renderer's error (empty when it works).
std::string WarmUpRenderer();

/// The column-major 4x4 GL projection for an OpenCV camera (see the file comment): clip =
/// P * [x_cam; 1]. Exposed for tests.
Eigen::Matrix4f GlProjectionFromK(const Eigen::Matrix3d& K, int width, int height,
                                  double near_plane, double far_plane);

/// A far plane that holds the whole mesh seen from `cam_from_world`: twice the largest vertex
/// depth, at least 2 scene units.
double FarPlaneFor(const Mesh& mesh, const Eigen::Isometry3d& cam_from_world);

}  // namespace mm
