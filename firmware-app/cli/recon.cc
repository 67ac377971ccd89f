// `monomesh recon A B --calib C --out DIR`: reconstruct one pair into a folder (no daemon).

#include <fstream>
#include <iostream>
#include <opencv2/imgcodecs.hpp>

#include "app/pair_job.h"
#include "calib/calib_io.h"
#include "calib/undistort.h"
#include "cli/commands.h"

namespace mm::cli {
namespace {

int RunRecon(const std::string& path_a, const std::string& path_b, const std::string& calib,
             const std::string& out_dir, const std::string& mesh_mode) {
  const BouguetCamera camera = LoadCalibration(calib);
  cv::Mat images[2];
  const std::string paths[2] = {path_a, path_b};
  for (int i = 0; i < 2; ++i) {
    images[i] = cv::imread(paths[i], cv::IMREAD_COLOR);
    if (images[i].empty()) {
      std::cerr << "monomesh recon: cannot read image " << paths[i] << "\n";
      return 1;
    }
  }
  BouguetCamera sized = camera;
  if (sized.width == 0) {
    sized.width = images[0].cols;
    sized.height = images[0].rows;
  }
  const Undistorter undistorter(sized);
  KeyframeInfo info[2];
  for (int i = 0; i < 2; ++i) {
    info[i].sequence = static_cast<uint64_t>(i);
    info[i].source = paths[i];
    images[i] = undistorter.Apply(images[i]);
  }
  PairOptions options;
  options.mesh_mode = *ParseMeshMode(mesh_mode);  // CLI11 checked the name.
  const PairJobResult result =
      RunPairJob(images[0], images[1], info[0], info[1], undistorter.output_camera(), options);
  if (!result.ok) {
    std::cerr << "monomesh recon: " << result.error << "\n";
    return 1;
  }
  std::filesystem::create_directories(out_dir);
  for (const SpoolFile& f : result.entry.files) {
    std::ofstream out(std::filesystem::path(out_dir) / f.name, std::ios::binary);
    out.write(f.bytes.data(), static_cast<std::streamsize>(f.bytes.size()));
    if (!out) {
      std::cerr << "monomesh recon: cannot write " << out_dir << "/" << f.name << "\n";
      return 1;
    }
  }
  const EntryReport::Counts& c = result.report.counts;
  std::cout << "points " << c.points << ", mesh " << c.mesh_vertices << " vertices / "
            << c.mesh_triangles << " triangles, " << result.report.timings_s.total_recon
            << " s; written to " << out_dir << "\n";
  return 0;
}

}  // namespace

Runner AddReconCommand(CLI::App& app) {
  auto* cmd = app.add_subcommand("recon", "Reconstruct a textured mesh from two images");
  struct Args {
    std::string image_a, image_b, calib, out_dir;
    std::string mesh_mode = MeshModeName(PairOptions{}.mesh_mode);
  };
  auto args = std::make_shared<Args>();
  cmd->add_option("A", args->image_a, "Keyframe A (texture source)")
      ->required()
      ->check(CLI::ExistingFile);
  cmd->add_option("B", args->image_b, "Keyframe B")->required()->check(CLI::ExistingFile);
  cmd->add_option("--calib", args->calib, "Calibration (TOML)")
      ->required()
      ->check(CLI::ExistingFile);
  cmd->add_option("--out", args->out_dir, "Output folder")->required();
  cmd->add_option("--mesh-mode", args->mesh_mode,
                  "The mesh: dense (from the dense depth of A) or sparse (Delaunay of the "
                  "triangulated points)")
      ->capture_default_str()
      ->check(CLI::IsMember({"dense", "sparse"}));
  return [cmd, args]() -> int {
    if (!cmd->parsed()) return -1;
    return RunRecon(args->image_a, args->image_b, args->calib, args->out_dir, args->mesh_mode);
  };
}

}  // namespace mm::cli
