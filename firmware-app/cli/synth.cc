// `monomesh synth --scene l-corridor --out DIR [--frames N] [--fps F] [--size WxH] [--calib C]
//  [--seed S] [--path walk|rotate|forward]`: a synthetic corridor sequence with exact ground
// truth as a TUM-format folder (synth/sequence.h holds the logic, docs/synth.md the formats).

#include <cstdio>
#include <iostream>

#include "calib/calib_io.h"
#include "cli/commands.h"
#include "synth/sequence.h"

namespace mm::cli {
namespace {

struct SynthArgs {
  std::string scene = "l-corridor", out, size, calib, path = "walk";
  int frames = SynthOptions{}.frames;
  double fps = SynthOptions{}.fps;
  uint64_t seed = CorridorOptions{}.seed;
  int png_compression = SynthOptions{}.png_compression;
};

int RunSynth(const SynthArgs& args) {
  SynthOptions options;
  options.out = args.out;
  options.scene = args.scene;
  options.frames = args.frames;
  options.fps = args.fps;
  options.corridor.seed = args.seed;
  options.png_compression = args.png_compression;
  const auto kind = ParseCameraPathKind(args.path);
  if (!kind) {
    std::cerr << "monomesh synth: --path: unknown '" << args.path
              << "' (known: walk, rotate, forward)\n";
    return 2;
  }
  options.path.kind = *kind;
  int width = 0, height = 0;
  if (!args.size.empty()) {
    char tail = 0;
    if (std::sscanf(args.size.c_str(), "%dx%d%c", &width, &height, &tail) != 2 || width <= 0 ||
        height <= 0) {
      std::cerr << "monomesh synth: --size: expected WxH (e.g. 320x240), got '" << args.size
                << "'\n";
      return 2;
    }
  }
  if (!args.calib.empty()) {
    BouguetCamera camera = LoadCalibration(args.calib);
    if (camera.width <= 0 && width <= 0) {
      width = 640;
      height = 480;
    }
    if (camera.width <= 0) {  // No image size in the file: the calibration is for --size.
      camera.width = width;
      camera.height = height;
    }
    options.camera = width > 0 ? ScaleCamera(camera, width, height) : camera;
  } else {
    options.camera = width > 0 ? DefaultSynthCamera(width, height) : DefaultSynthCamera();
  }
  if (const std::string problem = options.Check(); !problem.empty()) {
    std::cerr << "monomesh synth: " << problem << "\n";
    return 2;
  }
  const SynthSummary s = WriteSyntheticSequence(options);
  if (!s.success) {
    std::cerr << "monomesh synth: " << s.failure_reason << "\n";
    return 1;
  }
  std::printf(
      "synth: %d frames (%.2f s at %.3g fps, %s path %.2f m) of %s, %dx%d%s, seed %llu -> %s\n",
      s.frames, s.duration_s, options.fps, args.path.c_str(), s.path_length_m,
      options.scene.c_str(), options.camera.width, options.camera.height,
      s.distorted ? " distorted" : "", static_cast<unsigned long long>(args.seed),
      options.out.string().c_str());
  std::printf(
      "  scene %.2f s (%d quads, %.1f mm per texel), setup %.2f s (render %dx%d), "
      "render %.2f s, write %.2f s\n",
      s.scene_s, s.quads, 1000.0 / s.texels_per_m, s.setup_s, s.render_width, s.render_height,
      s.render_s, s.write_s);
  std::printf("  total %.2f s, %.1f ms per frame (%s)\n", s.total_s, s.per_frame_ms(),
              s.gl_renderer.c_str());
  return 0;
}

}  // namespace

Runner AddSynthCommand(CLI::App& app) {
  auto* cmd = app.add_subcommand(
      "synth", "Render a synthetic corridor sequence with exact ground truth (TUM format)");
  auto args = std::make_shared<SynthArgs>();
  cmd->add_option("--scene", args->scene, "Scene (l-corridor)")->capture_default_str();
  cmd->add_option("--out", args->out, "Folder to write (rgb/, depth/, *.txt, calib.toml)")
      ->required();
  cmd->add_option("--frames", args->frames, "Number of frames")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  cmd->add_option("--fps", args->fps, "Frame rate (timestamps; walking speed ~1 m/s)")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  cmd->add_option("--size", args->size,
                  "Image size WxH (default 640x480, or the calibration's; scales the camera)");
  cmd->add_option("--calib", args->calib,
                  "Camera (TOML or Calib_Results.m); with distortion (kc) the frames are "
                  "distorted with it")
      ->check(CLI::ExistingFile);
  cmd->add_option("--seed", args->seed, "Seed of textures and furniture")->capture_default_str();
  cmd->add_option("--path", args->path, "Camera path: walk | rotate | forward")
      ->capture_default_str();
  cmd->add_option("--png-compression", args->png_compression, "PNG zlib level 0-9")
      ->capture_default_str();
  return [cmd, args]() -> int {
    if (!cmd->parsed()) return -1;
    return RunSynth(*args);
  };
}

}  // namespace mm::cli
