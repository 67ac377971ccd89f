// The report of a pair job (MakeEntryReport, ReportScale) and its brief text (BriefReport).
// report.json's writing is in report_write.cc, its reading in report_read.cc.
#include "entry/report.h"

#include <Eigen/Geometry>
#include <string>
#include <vector>

#include "base/version.h"

namespace mm {
namespace {

using json = nlohmann::json;

// "reason; reason" of the source views the dense stage left out.
std::string JoinLeftOut(const std::vector<std::string>& reasons) {
  std::string out;
  for (const std::string& reason : reasons) out += (out.empty() ? "" : "; ") + reason;
  return out;
}

}  // namespace

EntryReport::Scale ReportScale(const ScaleEstimate& scale) {
  return {.source = ScaleSourceName(scale.source),
          .units = scale.scaled() ? "metres" : "baseline",
          .metres_per_unit = scale.scaled() ? scale.metres_per_unit : 1.0,
          .uncertainty_rel = scale.uncertainty_rel,
          .odometry_metres_per_unit = scale.odometry_metres_per_unit,
          .floor_metres_per_unit = scale.floor_metres_per_unit,
          .why_not = scale.why_not};
}

EntryReport MakeEntryReport(const PairReconstruction& r, const KeyframeInfo& a,
                            const KeyframeInfo& b, const BouguetCamera& camera,
                            const PairOptions& options, bool features_a_precomputed,
                            std::span<const KeyframeBTry> tries, const ScaleEstimate& scale) {
  const TwoViewResult& g = r.geometry;
  EntryReport report;
  report.monomesh_version = kMonomeshVersion;
  report.success = r.success;
  report.failure_reason = r.failure_reason;
  report.pair_classification = {.kind = PairKindName(g.classification.kind),
                                .explanation = g.classification.explanation,
                                .f_inliers = g.classification.f_inliers,
                                .h_inliers = g.classification.h_inliers,
                                .median_flow_px = g.classification.median_flow_px};
  report.ransac_f = {.iterations = g.ransac_f.iterations,
                     .required_iterations = g.ransac_f.required_iterations,
                     .inliers = g.ransac_f.inliers.size(),
                     .inlier_rms_px = g.ransac_f.inlier_rms_px};
  report.bundle_adjustment = {.ran = g.bundle.ran,
                              .converged = g.bundle.converged,
                              .iterations = g.bundle.iterations,
                              .adjusted_points = g.bundle.num_points,
                              .initial_rms_px = g.bundle.initial_rms_px,
                              .final_rms_px = g.bundle.final_rms_px,
                              .message = g.bundle.message};
  report.keyframe_a_features_precomputed = features_a_precomputed;
  for (const KeyframeBTry& t : tries) {
    const bool is_this = &t == &tries.back();
    report.keyframe_b_tries.push_back(
        {.frame = t.frame_sequence,
         .seconds_after_a = t.seconds_after_a,
         .gate_parallax_deg = t.gate_parallax_deg,
         .tracks = t.tracks,
         .after_lost_track = t.after_lost_track,
         .accepted = is_this ? r.success : t.accepted,
         .failure = TwoViewFailureName(is_this ? g.failure : t.failure),
         .reason = is_this ? r.failure_reason : t.reason});
  }
  report.keyframe_a = a;
  report.keyframe_b = b;
  report.camera = {.width = camera.width,
                   .height = camera.height,
                   .fc = camera.fc,
                   .cc = camera.cc,
                   .alpha_c = camera.alpha_c,
                   .kc = camera.kc};
  const Eigen::Quaterniond q(g.rotation);
  report.relative_pose.rotation = g.rotation;
  report.relative_pose.quaternion_wxyz = {q.w(), q.x(), q.y(), q.z()};
  report.relative_pose.translation = g.translation;
  report.scale = ReportScale(scale);
  report.counts = {.features_a = r.features_a,
                   .features_b = r.features_b,
                   .matches = r.matches,
                   .gate_tracks = r.tracks,
                   .gate_tracks_used = r.tracks_used,
                   .gate_track_inliers = r.track_inliers,
                   .inliers = g.num_inliers,
                   .points = g.points_in_cam_a.size(),
                   .mesh_vertices = r.mesh.vertices.size(),
                   .mesh_triangles = r.mesh.triangles.size(),
                   .mesh_dropped_depth_discontinuity = r.mesh_summary.dropped_depth_discontinuity,
                   .mesh_dropped_grazing_angle = r.mesh_summary.dropped_grazing_angle};
  report.meshing = {.mode = MeshModeName(r.mesh_mode),
                    .dense_valid_fraction = r.dense_valid_fraction,
                    .dense_planes = r.dense_planes,
                    .dense_views_between = r.intermediate_views_used - r.views_before_a_used,
                    .dense_views_before_a = r.views_before_a_used,
                    .dense_views_left_out = JoinLeftOut(r.intermediate_failures),
                    .dense_dropped_no_depth = r.dense_mesh_summary.dropped_no_depth,
                    .dense_dropped_bridging = r.dense_mesh_summary.dropped_bridging,
                    .dense_dropped_discontinuity = r.dense_mesh_summary.dropped_discontinuity,
                    .dense_fallback_reason = r.dense_failure_reason,
                    .voxel_size = r.mesh_summary.voxel_size,
                    .occupied_cells = r.mesh_summary.occupied_cells,
                    .kept_cells = r.mesh_summary.kept_cells,
                    .delaunay_triangles = r.mesh_summary.delaunay_triangles,
                    .max_depth_ratio = options.mesh.max_depth_ratio,
                    .max_grazing_angle_deg = options.mesh.max_grazing_angle_deg,
                    .min_points_per_cell = options.mesh.min_points_per_cell,
                    .voxel_vertex = options.mesh.voxel_vertex == VoxelVertex::kCentroid
                                        ? "centroid"
                                        : "cell_centre"};
  report.quality = {.median_triangulation_angle_deg = g.median_triangulation_angle_deg,
                    .reprojection_rms_px = g.reprojection_rms_px};
  report.timings_s.features_a = r.times.features_a_s;
  report.timings_s.features_b = r.times.features_b_s;
  report.timings_s.matching = r.times.matching_s;
  report.timings_s.geometry = r.times.geometry_s;
  report.timings_s.dense = r.times.dense_s;
  report.timings_s.meshing = r.times.meshing_s;
  report.timings_s.total_recon = r.times.total_s();
  return report;
}

std::string BriefReport(const EntryReport& r) {
  std::string out;
  auto line = [&out](const std::string& key, const std::string& value) {
    out += key + " " + value + "\n";
  };
  line("success", r.success ? "true" : "false");
  if (!r.success) line("failure", r.failure_reason);
  line("pair", r.pair_classification.kind);
  line("features_a", std::to_string(r.counts.features_a));
  line("features_b", std::to_string(r.counts.features_b));
  line("matches", std::to_string(r.counts.matches));
  line("gate_tracks_used", std::to_string(r.counts.gate_tracks_used));
  line("inliers", std::to_string(r.counts.inliers));
  line("gate_track_inliers", std::to_string(r.counts.gate_track_inliers));
  line("points", std::to_string(r.counts.points));
  line("mesh_vertices", std::to_string(r.counts.mesh_vertices));
  line("mesh_triangles", std::to_string(r.counts.mesh_triangles));
  // "dense 0.81" (the share of A with a dense depth) or "sparse", with the fallback's reason.
  std::string mesh_mode = r.meshing.mode;
  if (mesh_mode == "dense") {
    mesh_mode += " " + std::to_string(r.meshing.dense_valid_fraction);
  } else if (!r.meshing.dense_fallback_reason.empty()) {
    mesh_mode += " (" + r.meshing.dense_fallback_reason + ")";
  }
  line("mesh_mode", mesh_mode);
  line("median_triangulation_angle_deg", std::to_string(r.quality.median_triangulation_angle_deg));
  line("b_tries", std::to_string(r.keyframe_b_tries.size()));
  line("total_recon_s", std::to_string(r.timings_s.total_recon));
  line("scale",
       r.scale.units == "metres"
           ? r.scale.source + " " + std::to_string(r.scale.metres_per_unit) + " m/unit"
           : "none (up to scale" +
                 (r.scale.why_not.empty() ? std::string(")") : ": " + r.scale.why_not + ")"));
  return out;
}

}  // namespace mm
