#pragma once
// One capture's work after both keyframes are in: reconstruct the pair and encode everything a
// spool entry holds (mesh.glb, mesh.ply, mesh.obj + mesh.mtl + texture.jpg, points.ply, the
// COLMAP model cameras.txt + images.txt + points3D.txt with keyframe_b.jpg, preview.png,
// calibration.toml, report.json). Shared by `monomesh recon` and the daemon's worker.

#include <nlohmann/json.hpp>
#include <span>
#include <string>
#include <vector>

#include "calib/camera_model.h"
#include "recon/pipeline.h"
#include "session/capture_session.h"
#include "spool/spool.h"

namespace mm {

/// Where a keyframe came from, for the report.
struct KeyframeInfo {
  uint64_t sequence = 0;
  double source_time_s = 0.0;
  int64_t capture_time_ns = 0;
  std::string source;
};

struct PairJobResult {
  bool ok = false;
  std::string error;               ///< The reconstruction's failure reason.
  std::vector<SpoolFile> files;    ///< The entry's files (only when ok).
  nlohmann::json report;           ///< Also written as report.json (always filled).
  PairReconstruction recon;
};

/// `image_a`/`image_b` are undistorted BGR8 frames seen through `camera` (no distortion).
/// `features_a`, when given, are keyframe A's features from ExtractKeyframeFeatures (computed
/// while the gate waited for B), so only B's are computed here.
/// `tracks`: the keyframe gate's tracks from A to B (further correspondences); `tries`: the
/// capture's B tries so far, the last being this B (the report lists them).
PairJobResult RunPairJob(const cv::Mat& image_a, const cv::Mat& image_b, const KeyframeInfo& a,
                         const KeyframeInfo& b, const BouguetCamera& camera,
                         const PairOptions& options, const Features* features_a = nullptr,
                         std::span<const TrackCorrespondence> tracks = {},
                         std::span<const KeyframeBTry> tries = {});

}  // namespace mm
