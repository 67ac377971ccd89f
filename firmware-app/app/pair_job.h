#pragma once
// One capture's work after both keyframes are in: reconstruct the pair (recon/pipeline.h) and
// make the spool entry from it (entry/entry.h). Shared by `monomesh recon` and the daemon's
// worker.

#include <Eigen/Core>
#include <optional>
#include <span>
#include <string>

#include "calib/camera_model.h"
#include "entry/entry.h"
#include "entry/report.h"
#include "recon/pipeline.h"
#include "scale/metric_scale.h"
#include "session/capture_session.h"

namespace mm {

/// The metric scale asked of a pair job (scale/metric_scale.h): the options (source none:
/// unscaled) and the odometry's positions at the keyframes' capture times, or why there are none.
struct PairScaleInputs {
  ScaleOptions options;
  std::optional<Eigen::Vector3d> odometry_a_m;
  std::optional<Eigen::Vector3d> odometry_b_m;
  std::string odometry_why_not;
};

struct PairJobResult {
  bool ok = false;
  std::string error;   ///< The reconstruction's failure reason.
  EncodedEntry entry;  ///< The entry's files (only when ok).
  EntryReport report;  ///< Also written as report.json (always filled).
  PairReconstruction recon;
};

/// `image_a`/`image_b` are undistorted BGR8 frames seen through `camera` (no distortion).
/// `features_a`, when given, are keyframe A's features from ExtractKeyframeFeatures (computed
/// while the gate waited for B), so only B's are computed here.
/// `tracks`: the keyframe gate's tracks from A to B (further correspondences); `between`: the
/// frames between A and B with the tracks at them (further views for the dense stage); `tries`: the
/// capture's B tries so far, the last being this B (the report lists them). `scale`: when a
/// source scales the pair, the reconstruction, the report and every file are in metres.
PairJobResult RunPairJob(const cv::Mat& image_a, const cv::Mat& image_b, const KeyframeInfo& a,
                         const KeyframeInfo& b, const BouguetCamera& camera,
                         const PairOptions& options, const Features* features_a = nullptr,
                         std::span<const TrackCorrespondence> tracks = {},
                         std::span<const SourceView> between = {},
                         std::span<const KeyframeBTry> tries = {},
                         const PairScaleInputs& scale = {});

}  // namespace mm
