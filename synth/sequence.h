#pragma once
// `monomesh synth`: renders a camera path through the synthetic corridor (synth/corridor.h,
// synth/camera_path.h) with mm_render's EGL renderer and writes a TUM RGB-D format folder
// (Sturm et al., IROS 2012) with exact ground truth:
//   rgb/<t>.png      colour, 8-bit BGR
//   depth/<t>.png    16-bit, value / 5000 = z in metres (0 = nothing, or beyond 13.1 m)
//   rgb.txt, depth.txt          `timestamp path`
//   groundtruth.txt             `timestamp tx ty tz qx qy qz qw`, world_from_cam, one per frame
//   calib.toml, Calib_Results.m the camera (calib/calib_io.h, calib/calib_results_m.h)
// A camera with distortion (kc) gets distorted frames: a finer pinhole image covering every ray
// of the distorted image is rendered and resampled through the Bouguet projection (colour
// bilinear; depth by bilinear inverse depth, exact on planes, nearest across edges). Without
// distortion the frame is rendered directly with KK (skew included): depth is exact at the pixel
// centres. The pose of a line is evaluated at the time written on it.
//
// Thread-safety: creates its own EGL context on the calling thread; reentrant otherwise.

#include <cstdint>
#include <filesystem>
#include <string>

#include "calib/camera_model.h"
#include "synth/camera_path.h"
#include "synth/corridor.h"

namespace mm {

struct SynthOptions {
  std::filesystem::path out;         ///< Folder to write (created).
  std::string scene = "l-corridor";  ///< The only scene so far.
  int frames = 300;
  double fps = 30.0;
  double start_time_s = 1000.0;  ///< Timestamp of frame 0 (written with 6 decimals).
  BouguetCamera camera;          ///< With width/height; DefaultSynthCamera() if unset.
  CorridorOptions corridor;      ///< Its seed is the sequence's seed.
  CameraPathOptions path;
  /// Distorted cameras: the pinhole render's focal length relative to the camera's (finer than
  /// the output, so the resampling does not blur).
  double render_scale = 1.5;
  /// PNG zlib level: 1 is ~5x faster than OpenCV's default 3 for ~10 % larger files.
  int png_compression = 1;
  [[nodiscard]] std::string Check() const;
};

/// A plausible 640x480 camera (fc 525, principal point in the middle, no distortion), scaled to
/// width x height.
BouguetCamera DefaultSynthCamera(int width = 640, int height = 480);

/// `camera` for images of width x height (fc and cc scaled per axis; distortion unchanged).
BouguetCamera ScaleCamera(const BouguetCamera& camera, int width, int height);

struct SynthSummary {
  bool success = false;
  std::string failure_reason;
  int frames = 0;
  double duration_s = 0.0;  ///< Sequence time covered (frames / fps).
  double path_length_m = 0.0;
  int quads = 0, triangles = 0;
  double texels_per_m = 0.0;
  bool distorted = false;
  int render_width = 0, render_height = 0;  ///< The pinhole render (finer when distorted).
  double scene_s = 0.0;                     ///< Scene and atlas building.
  double setup_s = 0.0;                     ///< EGL, upload, distortion maps.
  double render_s = 0.0;                    ///< All frames: draw, read back, resample.
  double write_s = 0.0;                     ///< All frames: PNG encoding and files.
  double total_s = 0.0;
  std::string gl_renderer;
  [[nodiscard]] double per_frame_ms() const { return frames > 0 ? 1000.0 * total_s / frames : 0; }
};

/// Builds the scene, renders every frame and writes the folder. Failures (options, EGL, files)
/// are reported in the summary.
SynthSummary WriteSyntheticSequence(const SynthOptions& options);

/// The TUM timestamp of frame i: start + i / fps rounded to the 6 decimals written.
double SynthFrameTime(const SynthOptions& options, int i);

}  // namespace mm
