// monomesh: the command-line tool. Wiring only; each subcommand calls a library.
//   monomesh recon A B --calib C --out DIR     reconstruct one pair into DIR
//   monomesh ctl trigger|status|ping           talk to a running monomeshd

#include <CLI/CLI.hpp>
#include <spdlog/spdlog.h>

#include <fstream>
#include <iostream>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <thread>

#include "app/config.h"
#include "app/control.h"
#include "app/logging.h"
#include "app/pair_job.h"
#include "calib/calib_io.h"
#include "calib/undistort.h"

namespace {

using json = nlohmann::json;

int RunRecon(const std::string& path_a, const std::string& path_b, const std::string& calib,
             const std::string& out_dir) {
  const mm::BouguetCamera camera = mm::LoadCalibration(calib);
  cv::Mat images[2];
  const std::string paths[2] = {path_a, path_b};
  for (int i = 0; i < 2; ++i) {
    images[i] = cv::imread(paths[i], cv::IMREAD_COLOR);
    if (images[i].empty()) {
      std::cerr << "monomesh recon: cannot read image " << paths[i] << "\n";
      return 1;
    }
  }
  mm::BouguetCamera sized = camera;
  if (sized.width == 0) {
    sized.width = images[0].cols;
    sized.height = images[0].rows;
  }
  const mm::Undistorter undistorter(sized);
  mm::KeyframeInfo info[2];
  for (int i = 0; i < 2; ++i) {
    info[i].sequence = static_cast<uint64_t>(i);
    info[i].source = paths[i];
    images[i] = undistorter.Apply(images[i]);
  }
  const mm::PairJobResult result = mm::RunPairJob(images[0], images[1], info[0], info[1],
                                                  undistorter.output_camera(), mm::PairOptions{});
  if (!result.ok) {
    std::cerr << "monomesh recon: " << result.error << "\n";
    return 1;
  }
  std::filesystem::create_directories(out_dir);
  for (const mm::SpoolFile& f : result.files) {
    std::ofstream out(std::filesystem::path(out_dir) / f.name, std::ios::binary);
    out.write(f.bytes.data(), static_cast<std::streamsize>(f.bytes.size()));
    if (!out) {
      std::cerr << "monomesh recon: cannot write " << out_dir << "/" << f.name << "\n";
      return 1;
    }
  }
  const json& c = result.report["counts"];
  std::cout << "points " << c["points"] << ", mesh " << c["mesh_vertices"] << " vertices / "
            << c["mesh_triangles"] << " triangles, " << result.report["timings_s"]["total_recon"]
            << " s; written to " << out_dir << "\n";
  return 0;
}

int RunCtl(const std::string& command, std::filesystem::path socket, const std::string& config,
           double wait_s) {
  using namespace std::chrono_literals;
  if (!config.empty()) socket = mm::LoadDaemonConfig(config).control_socket;
  const json reply = json::parse(mm::SendControlCommand(socket, command, 5s));
  if (command != "trigger" || wait_s <= 0 || !reply.value("ok", false)) {
    std::cout << reply.dump(2) << "\n";
    return reply.value("ok", false) ? 0 : 1;
  }
  // Wait until the daemon reports the result of this capture.
  const uint64_t capture = reply["capture"].get<uint64_t>();
  std::cerr << "capture " << capture << " started; waiting up to " << wait_s << " s\n";
  const auto deadline = std::chrono::steady_clock::now() +
                        std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                            std::chrono::duration<double>(wait_s));
  while (std::chrono::steady_clock::now() < deadline) {
    const json status = json::parse(mm::SendControlCommand(socket, "status", 5s));
    const json& last = status["last_result"];
    if (last.is_object() && last.value("capture", uint64_t{0}) == capture) {
      std::cout << last.dump(2) << "\n";
      return last.value("ok", false) ? 0 : 1;
    }
    std::this_thread::sleep_for(100ms);
  }
  std::cerr << "monomesh ctl: capture " << capture << " did not finish within " << wait_s
            << " s\n";
  return 1;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"monomesh: capture-to-mesh appliance tool"};
  app.require_subcommand(1);

  auto* recon = app.add_subcommand("recon", "Reconstruct a textured mesh from two images");
  std::string image_a, image_b, calib, out_dir;
  recon->add_option("A", image_a, "Keyframe A (texture source)")->required()->check(CLI::ExistingFile);
  recon->add_option("B", image_b, "Keyframe B")->required()->check(CLI::ExistingFile);
  recon->add_option("--calib", calib, "Calibration (TOML)")->required()->check(CLI::ExistingFile);
  recon->add_option("--out", out_dir, "Output folder")->required();

  auto* ctl = app.add_subcommand("ctl", "Send a command to a running monomeshd");
  std::string command;
  std::string socket = "/run/monomesh/control.sock";
  std::string config;
  double wait_s = 0;
  ctl->add_option("command", command, "trigger | status | ping")
      ->required()
      ->check(CLI::IsMember({"trigger", "status", "ping"}));
  ctl->add_option("--socket", socket, "Control socket")->capture_default_str();
  ctl->add_option("--config", config, "Take the socket path from this daemon config");
  ctl->add_option("--wait", wait_s, "With trigger: wait up to this many seconds for the result");

  CLI11_PARSE(app, argc, argv);
  mm::SetupLogging("warn");
  try {
    if (recon->parsed()) return RunRecon(image_a, image_b, calib, out_dir);
    if (ctl->parsed()) return RunCtl(command, socket, config, wait_s);
  } catch (const mm::CalibrationError& e) {
    std::cerr << "monomesh: calibration: " << e.what() << "\n";
    return 78;
  } catch (const mm::ConfigError& e) {
    std::cerr << "monomesh: config: " << e.what() << "\n";
    return 78;
  } catch (const std::exception& e) {
    std::cerr << "monomesh: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
