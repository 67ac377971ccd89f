// `monomesh calibrate --images DIR --board COLSxROWS --square MM --out DIR`: chessboard
// calibration in the Bouguet model (calib/calibrate.h); writes Calib_Results.m, calibration.toml
// and calibration_report.png.

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <opencv2/imgcodecs.hpp>
#include <sstream>

#include "calib/calib_io.h"
#include "calib/calib_results_m.h"
#include "calib/calibrate.h"
#include "cli/commands.h"

namespace mm::cli {
namespace {

namespace fs = std::filesystem;

bool IsImage(const fs::path& p) {
  std::string ext = p.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return std::tolower(c); });
  for (const char* e : {".png", ".jpg", ".jpeg", ".tif", ".tiff", ".bmp", ".pgm", ".ppm"}) {
    if (ext == e) return true;
  }
  return false;
}

// Natural order: Image2 before Image10, as the toolbox numbers its images.
bool NaturalLess(const std::string& a, const std::string& b) {
  size_t i = 0, j = 0;
  while (i < a.size() && j < b.size()) {
    if (std::isdigit(static_cast<unsigned char>(a[i])) &&
        std::isdigit(static_cast<unsigned char>(b[j]))) {
      size_t ie = i, je = j;
      while (ie < a.size() && std::isdigit(static_cast<unsigned char>(a[ie]))) ++ie;
      while (je < b.size() && std::isdigit(static_cast<unsigned char>(b[je]))) ++je;
      const std::string na = a.substr(i, ie - i), nb = b.substr(j, je - j);
      if (na.size() != nb.size()) return na.size() < nb.size();
      if (na != nb) return na < nb;
      i = ie;
      j = je;
    } else {
      if (a[i] != b[j]) return a[i] < b[j];
      ++i;
      ++j;
    }
  }
  return a.size() - i < b.size() - j;
}

bool WriteText(const fs::path& p, const std::string& text) {
  std::ofstream out(p, std::ios::binary);
  out << text;
  return static_cast<bool>(out);
}

struct Args {
  std::string images, board, out, est_dist = "1,1,1,1,0";
  double square = 0;
  bool est_alpha = false;
  int center_optim = 1, est_aspect_ratio = 1;
};

int RunCalibrate(const Args& a) {
  CalibrateOptions o;
  const std::optional<cv::Size> board = ParseBoardSize(a.board);
  if (!board) {
    std::cerr << "monomesh calibrate: --board must be COLSxROWS (inner corners), e.g. 9x6\n";
    return 2;
  }
  o.board = *board;
  const int cols = board->width, rows = board->height;
  o.square = a.square;
  o.est_alpha = a.est_alpha;
  o.center_optim = a.center_optim != 0;
  o.est_aspect_ratio = a.est_aspect_ratio != 0;
  std::istringstream ds(a.est_dist);
  std::string item;
  size_t n = 0;
  while (std::getline(ds, item, ',')) {
    if (n >= 5 || (item != "0" && item != "1")) {
      n = 99;
      break;
    }
    o.est_dist[n++] = item == "1" ? 1 : 0;
  }
  if (n != 5) {
    std::cerr << "monomesh calibrate: --est-dist must be five 0/1 values, e.g. 1,1,1,1,0\n";
    return 2;
  }
  if (const std::string problem = o.Check(); !problem.empty()) {
    std::cerr << "monomesh calibrate: " << problem << "\n";
    return 2;
  }

  std::vector<std::string> files;
  for (const auto& entry : fs::directory_iterator(a.images)) {
    if (entry.is_regular_file() && IsImage(entry.path())) {
      files.push_back(entry.path().filename().string());
    }
  }
  std::sort(files.begin(), files.end(), NaturalLess);
  std::vector<std::string> names;
  std::vector<cv::Mat> images;
  for (const auto& f : files) {
    cv::Mat img = cv::imread((fs::path(a.images) / f).string(), cv::IMREAD_GRAYSCALE);
    if (img.empty()) {
      std::cerr << "skipped (unreadable): " << f << "\n";
      continue;
    }
    names.push_back(f);
    images.push_back(img);
  }
  if (images.empty()) {
    std::cerr << "monomesh calibrate: no images in " << a.images << "\n";
    return 1;
  }
  std::cout << "calibrating from " << images.size() << " images, board " << cols << "x" << rows
            << ", square " << o.square << "\n";
  const CalibrateResult r = CalibrateFromImages(names, images, o);
  for (const auto& img : r.images) {
    if (!img.used) std::cout << "board not found, skipped: " << img.name << "\n";
  }
  if (!r.ok) {
    std::cerr << "monomesh calibrate: " << r.failure_reason << "\n";
    return 1;
  }
  for (size_t i = 0; i < r.images.size(); ++i) {
    if (r.images[i].used) {
      std::cout << "image " << i + 1 << " " << r.images[i].name << ": RMS " << r.images[i].rms_px
                << " px\n";
    }
  }
  std::cout << r.Summary() << "\n";
  const fs::path out(a.out);
  fs::create_directories(out);
  if (!WriteText(out / "Calib_Results.m", FormatCalibResultsM(r.ToCalibResults())) ||
      !WriteText(out / "calibration.toml", FormatCalibrationToml(r.camera)) ||
      !cv::imwrite((out / "calibration_report.png").string(), RenderCalibrationReport(r))) {
    std::cerr << "monomesh calibrate: cannot write into " << out << "\n";
    return 1;
  }
  std::cout << "written: " << (out / "Calib_Results.m").string() << ", "
            << (out / "calibration.toml").string() << ", "
            << (out / "calibration_report.png").string() << "\n";
  return 0;
}

}  // namespace

Runner AddCalibrateCommand(CLI::App& app) {
  auto* cmd = app.add_subcommand("calibrate", "Calibrate the camera from chessboard images");
  auto args = std::make_shared<Args>();
  cmd->add_option("--images", args->images, "Folder of board images")
      ->required()
      ->check(CLI::ExistingDirectory);
  cmd->add_option("--board", args->board, "Inner corners COLSxROWS, e.g. 9x6")->required();
  cmd->add_option("--square", args->square, "Square size (mm)")->required();
  cmd->add_flag("--est-alpha", args->est_alpha, "Estimate the skew alpha_c");
  cmd->add_option("--est-dist", args->est_dist,
                  "Which of kc1..kc5 to estimate (default 1,1,1,1,0)");
  cmd->add_option("--center-optim", args->center_optim, "Estimate the principal point (0|1)")
      ->check(CLI::Range(0, 1));
  cmd->add_option("--est-aspect-ratio", args->est_aspect_ratio, "Estimate fc2/fc1 (0|1)")
      ->check(CLI::Range(0, 1));
  cmd->add_option("--out", args->out, "Output folder")->required();
  return [cmd, args]() -> int {
    if (!cmd->parsed()) return -1;
    return RunCalibrate(*args);
  };
}

}  // namespace mm::cli
