#pragma once
// A walk's spool entry (docs/walk.md): the map of the walk's largest segment in its first
// keyframe's frame, in metres when the walk's scale is known. Files: map.glb (the keyframe mesh
// parts, each textured by its keyframe), map.ply (the same merged, vertex colours), trajectory.txt
// (the segment's keyframe poses, camera-to-world, TUM format: `timestamp tx ty tz qx qy qz qw`),
// keyframe_NNNN.jpg (every keyframe), points.ply (the segment's map points), the COLMAP text model
// of the segment (cameras.txt, images.txt, points3D.txt), calibration.toml, preview.png (plan view
// and oblique view) and, last, report.json (WalkReport).
//
// Thread-safety: renders the preview with a Renderer of its own on the calling thread.

#include <chrono>
#include <string>
#include <vector>

#include "calib/camera_model.h"
#include "entry/entry.h"
#include "entry/report.h"
#include "map/walk_map.h"
#include "map/walk_mesh.h"
#include "map/walk_refine.h"
#include "scale/metric_scale.h"

namespace mm {

struct WalkEntryInput {
  const WalkMap* map = nullptr;
  const WalkMesh* mesh = nullptr;              ///< Of the map segment (LargestSegment).
  std::vector<std::string> keyframe_jpegs;     ///< Per map keyframe: the undistorted image.
  std::vector<KeyframeInfo> keyframe_infos;    ///< Per map keyframe.
  std::vector<WalkKeyframeSummary> summaries;  ///< Per map keyframe: its registration.
  BouguetCamera camera;                        ///< Of the undistorted frames (no distortion).
  /// The walk's scale (EstimateScale on the map segment); when it scaled, every length the
  /// entry holds is in metres.
  ScaleEstimate scale;
  std::string stop_reason;
  uint64_t frames = 0;
  double walk_seconds = 0.0;
  TrackRefineSummary refinement;  ///< The map's refinement after the walk.
  double refinement_seconds = 0.0;
};

/// A keyframe image as the walk keeps it (BGR8 or GRAY8 in; JPEG, colour) and back (BGR8;
/// empty when the bytes are not a JPEG).
std::string EncodeKeyframeJpeg(const cv::Mat& image);
cv::Mat DecodeKeyframeJpeg(const std::string& jpeg);

/// The name of keyframe `index`'s image in the entry.
std::string WalkKeyframeImageName(int index);

/// Encodes the walk; fills `report` (written as report.json, last).
EncodedEntry EncodeWalkEntry(const WalkEntryInput& in,
                             std::chrono::steady_clock::time_point started, WalkReport* report);

/// Reads `<entry_dir>/report.json` as a walk's report. Returns "" or what went wrong.
[[nodiscard]] std::string ReadWalkReport(const std::filesystem::path& entry_dir,
                                         WalkReport* report);

/// "walk" or "pair" for the entry's report.json ("" and *error when it cannot be read).
std::string ReadEntryKind(const std::filesystem::path& entry_dir, std::string* error);

}  // namespace mm
