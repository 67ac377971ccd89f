#include "app/pair_job.h"

#include <chrono>

#include "base/wall_clock.h"

namespace mm {

PairJobResult RunPairJob(const cv::Mat& image_a, const cv::Mat& image_b, const KeyframeInfo& a,
                         const KeyframeInfo& b, const BouguetCamera& camera,
                         const PairOptions& options, const Features* features_a,
                         std::span<const TrackCorrespondence> tracks,
                         std::span<const SourceView> between, std::span<const KeyframeBTry> tries,
                         const PairScaleInputs& scale) {
  PairJobResult out;
  const auto start = std::chrono::steady_clock::now();
  out.recon = features_a != nullptr
                  ? ReconstructPair(*features_a, image_a, image_b, camera, options, tracks, between)
                  : ReconstructPair(image_a, image_b, camera, options, between);
  ScaleEstimate metric;
  if (out.recon.success) {
    metric = EstimateScale({.odometry_a_m = scale.odometry_a_m,
                            .odometry_b_m = scale.odometry_b_m,
                            .odometry_why_not = scale.odometry_why_not,
                            .baseline_units = out.recon.geometry.translation.norm(),
                            .points_in_a = out.recon.SurfacePointsInA(),
                            .gray_a = ToGray(image_a),
                            .K = camera.K()},
                           scale.options);
    if (metric.scaled()) ScalePairReconstruction(metric.metres_per_unit, &out.recon);
  }
  out.report =
      MakeEntryReport(out.recon, a, b, camera, options, features_a != nullptr, tries, metric);
  // Capture times are on this boot's CLOCK_MONOTONIC (frames read from files have none).
  if (a.capture_time_ns != 0 || b.capture_time_ns != 0) out.report.boot_id = BootId();
  if (!out.recon.success) {
    out.error = out.recon.failure_reason;
    return out;
  }
  out.entry = EncodeEntry(out.recon, image_a, image_b, camera, start, &out.report);
  out.ok = true;
  return out;
}

}  // namespace mm
