// `monomesh snapshot --camera URI --out DIR [--count N] [--interval S] [--board COLSxROWS]`:
// collects raw frames from the appliance's own camera (the daemon's URIs, capture/source_uri.h)
// for `monomesh calibrate`. With --board only views where the chessboard is found are kept,
// so the operator moves the board between views until N are collected (docs/calibration.md).

#include <filesystem>
#include <iomanip>
#include <iostream>
#include <opencv2/imgcodecs.hpp>
#include <sstream>
#include <thread>

#include "calib/calibrate.h"
#include "capture/source_uri.h"
#include "cli/commands.h"

namespace mm::cli {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

struct Args {
  std::string camera, out, board;
  int count = 20;
  double interval_s = 2.0;
  double timeout_s = 600.0;
};

int RunSnapshot(const Args& a) {
  std::optional<cv::Size> board;
  if (!a.board.empty()) {
    board = ParseBoardSize(a.board);
    if (!board) {
      std::cerr << "monomesh snapshot: --board must be COLSxROWS (inner corners), e.g. 9x6\n";
      return 2;
    }
  }
  std::error_code ec;
  fs::create_directories(a.out, ec);
  if (ec) {
    std::cerr << "monomesh snapshot: cannot create " << a.out << ": " << ec.message() << "\n";
    return 1;
  }
  std::unique_ptr<FrameSource> source;
  try {
    source = CreateFrameSource(a.camera);
  } catch (const std::exception& e) {
    std::cerr << "monomesh snapshot: --camera: " << e.what() << "\n";
    return 2;
  }
  if (std::string error = source->Open(); !error.empty()) {
    std::cerr << "monomesh snapshot: " << a.camera << ": " << error
              << " (a running monomeshd holds the camera: stop it first)\n";
    return 1;
  }
  std::cout << "camera: " << source->Describe() << "\n";
  const auto interval =
      std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(a.interval_s));
  const auto deadline = Clock::now() + std::chrono::duration_cast<Clock::duration>(
                                           std::chrono::duration<double>(a.timeout_s));
  auto next = Clock::now();
  int saved = 0;
  Frame frame;
  while (saved < a.count) {
    if (Clock::now() > deadline) {
      std::cerr << "monomesh snapshot: " << saved << " of " << a.count << " views after "
                << a.timeout_s << " s (--timeout)\n";
      return 1;
    }
    std::string error;
    const ReadStatus status = source->Read(&frame, std::chrono::milliseconds(1000), &error);
    if (status == ReadStatus::kEndOfStream) {
      std::cerr << "monomesh snapshot: the camera ended after " << saved << " views\n";
      return 1;
    }
    if (status == ReadStatus::kError) {
      std::cerr << "monomesh snapshot: " << a.camera << ": " << error << "\n";
      return 1;
    }
    if (status != ReadStatus::kFrame || Clock::now() < next) continue;
    if (board && DetectBoard(frame.image, *board, /*subpix_half_window=*/0,
                             /*exhaustive=*/false)
                     .empty()) {
      continue;  // Keep reading: the next frame may show the board.
    }
    std::ostringstream name;
    name << "view_" << std::setw(3) << std::setfill('0') << saved << ".png";
    const fs::path path = fs::path(a.out) / name.str();
    if (!cv::imwrite(path.string(), frame.image)) {
      std::cerr << "monomesh snapshot: cannot write " << path.string() << "\n";
      return 1;
    }
    ++saved;
    std::cout << "view " << saved << "/" << a.count << ": " << path.string() << " ("
              << frame.image.cols << "x" << frame.image.rows << (board ? ", board found" : "")
              << ")\n"
              << std::flush;
    next = Clock::now() + interval;
  }
  source->Close();
  return 0;
}

}  // namespace

Runner AddSnapshotCommand(CLI::App& app) {
  auto* cmd = app.add_subcommand(
      "snapshot", "Collect calibration views from the appliance's camera (monomeshd stopped)");
  auto args = std::make_shared<Args>();
  cmd->add_option("--camera", args->camera, "Camera URI, as [camera] uri (v4l2:, libcamera:, ...)")
      ->required();
  cmd->add_option("--out", args->out, "Folder for view_NNN.png")->required();
  cmd->add_option("--count", args->count, "Views to collect")
      ->capture_default_str()
      ->check(CLI::Range(1, 1000));
  cmd->add_option("--interval", args->interval_s, "Seconds between views (time to move the board)")
      ->capture_default_str()
      ->check(CLI::Range(0.0, 3600.0));
  cmd->add_option("--board", args->board,
                  "Keep only views where this chessboard (inner corners, e.g. 9x6) is found");
  cmd->add_option("--timeout", args->timeout_s, "Give up after this many seconds")
      ->capture_default_str()
      ->check(CLI::Range(1.0, 86400.0));
  return [cmd, args]() -> int {
    if (!cmd->parsed()) return -1;
    return RunSnapshot(*args);
  };
}

}  // namespace mm::cli
