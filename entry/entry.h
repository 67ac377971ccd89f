#pragma once
// A spool entry, made and read in one place. EncodeEntry turns a reconstructed pair into the
// entry's files: mesh.glb (the primary output, texture inside), mesh.ply, mesh.obj + mesh.mtl +
// texture.jpg, keyframe_b.jpg, points.ply, the COLMAP text model (cameras.txt, images.txt,
// points3D.txt), calibration.toml (the camera used), preview.png and, last, report.json.
// WriteEntry hands them to the spool; ReadEntryReport reads an entry's report back.
//
// Thread-safety: EncodeEntry renders the preview with a Renderer of its own on the calling
// thread; the rest are pure functions (WriteEntry: see Spool).

#include <chrono>
#include <ctime>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "calib/camera_model.h"
#include "entry/report.h"
#include "recon/pipeline.h"
#include "spool/spool.h"

namespace mm {

/// The files of one entry, report.json last (a reader that sees it knows the other files).
struct EncodedEntry {
  std::vector<SpoolFile> files;
};

/// Encodes a successful pair (`recon.success`): `image_a`/`image_b` are the undistorted BGR8
/// keyframes seen through `camera` (no distortion). Completes `report` (preview, the preview
/// and encode timings; `started` is when the pair job began) and writes it as report.json.
EncodedEntry EncodeEntry(const PairReconstruction& recon, const cv::Mat& image_a,
                         const cv::Mat& image_b, const BouguetCamera& camera,
                         std::chrono::steady_clock::time_point started, EntryReport* report);

/// Commits the entry to the spool as `<spool>/<UTC of when>-<seq>/`.
[[nodiscard]] SpoolCommit WriteEntry(Spool& spool, const EncodedEntry& entry, std::time_t when);

/// Reads `<entry_dir>/report.json` as JSON, of either kind (ReportKind tells which). Returns ""
/// or what went wrong (naming the file).
[[nodiscard]] std::string ReadReportJson(const std::filesystem::path& entry_dir,
                                         nlohmann::json* report);

/// Reads `<entry_dir>/report.json` as a pair's report. Returns "" or what went wrong (naming the
/// file).
[[nodiscard]] std::string ReadEntryReport(const std::filesystem::path& entry_dir,
                                          EntryReport* report);

}  // namespace mm
