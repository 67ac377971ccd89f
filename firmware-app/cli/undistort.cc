// `monomesh undistort --calib C IN OUT`: undistorts one image (gray or colour) with the Bouguet
// model's remap tables (calib/undistort.h) and prints the camera of the output image.

#include <iostream>
#include <opencv2/imgcodecs.hpp>

#include "calib/calib_io.h"
#include "calib/undistort.h"
#include "cli/commands.h"

namespace mm::cli {
namespace {

int RunUndistort(const std::string& calib, const std::string& in, const std::string& out) {
  BouguetCamera camera = LoadCalibration(calib);
  const cv::Mat image = cv::imread(in, cv::IMREAD_UNCHANGED);
  if (image.empty()) {
    std::cerr << "monomesh undistort: cannot read image " << in << "\n";
    return 1;
  }
  if (camera.width == 0) {
    camera.width = image.cols;
    camera.height = image.rows;
  }
  const Undistorter undistorter(camera);
  const cv::Mat result = undistorter.Apply(image);
  if (!cv::imwrite(out, result)) {
    std::cerr << "monomesh undistort: cannot write " << out << "\n";
    return 1;
  }
  const BouguetCamera& o = undistorter.output_camera();
  std::cout << "written " << out << " (" << result.cols << "x" << result.rows
            << "); output camera fc = [" << o.fc.x() << " " << o.fc.y() << "], cc = [" << o.cc.x()
            << " " << o.cc.y() << "], alpha_c = " << o.alpha_c << ", kc = 0\n";
  return 0;
}

}  // namespace

Runner AddUndistortCommand(CLI::App& app) {
  auto* cmd = app.add_subcommand("undistort", "Undistort an image with a calibration");
  struct Args {
    std::string calib, in, out;
  };
  auto args = std::make_shared<Args>();
  cmd->add_option("--calib", args->calib, "Calibration (TOML or Calib_Results.m)")
      ->required()
      ->check(CLI::ExistingFile);
  cmd->add_option("IN", args->in, "Input image")->required()->check(CLI::ExistingFile);
  cmd->add_option("OUT", args->out, "Output image")->required();
  return [cmd, args]() -> int {
    if (!cmd->parsed()) return -1;
    return RunUndistort(args->calib, args->in, args->out);
  };
}

}  // namespace mm::cli
