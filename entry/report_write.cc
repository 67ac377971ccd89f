// report.json's writing: ToJson and FormatEntryReport of a pair's report, and of a walk's.
// The keys are spelled here and in report_read.cc only.
#include "entry/report.h"

#include <nlohmann/json.hpp>
#include <string>

#include "entry/json_text.h"

namespace mm {
namespace {

using json = nlohmann::json;

json KeyframeJson(const KeyframeInfo& k) {
  return {{"sequence", k.sequence},
          {"source_time_s", k.source_time_s},
          {"capture_time_ns", k.capture_time_ns},
          {"capture_realtime_ns", k.capture_realtime_ns},
          {"source", k.source}};
}

json CameraJson(const EntryReport::Camera& cam) {
  return {{"image_size", {cam.width, cam.height}},
          {"fc", {cam.fc.x(), cam.fc.y()}},
          {"cc", {cam.cc.x(), cam.cc.y()}},
          {"alpha_c", cam.alpha_c},
          {"kc", cam.kc}};
}

json ScaleJson(const EntryReport::Scale& scale) {
  return {{"source", scale.source},
          {"units", scale.units},
          {"metres_per_unit", scale.metres_per_unit},
          {"uncertainty_rel", scale.uncertainty_rel},
          {"odometry_metres_per_unit", scale.odometry_metres_per_unit},
          {"floor_metres_per_unit", scale.floor_metres_per_unit},
          {"why_not", scale.why_not}};
}

}  // namespace

json ToJson(const EntryReport& r) {
  json report;
  report["schema_version"] = r.schema_version;
  report["monomesh_version"] = r.monomesh_version;
  report["boot_id"] = r.boot_id;
  report["success"] = r.success;
  report["failure_reason"] = r.failure_reason;
  const auto& c = r.pair_classification;
  report["pair_classification"] = {{"kind", c.kind},
                                   {"explanation", c.explanation},
                                   {"f_inliers", c.f_inliers},
                                   {"h_inliers", c.h_inliers},
                                   {"median_flow_px", c.median_flow_px}};
  report["ransac_f"] = {{"iterations", r.ransac_f.iterations},
                        {"required_iterations", r.ransac_f.required_iterations},
                        {"inliers", r.ransac_f.inliers},
                        {"inlier_rms_px", r.ransac_f.inlier_rms_px}};
  const auto& ba = r.bundle_adjustment;
  report["bundle_adjustment"] = {{"ran", ba.ran},
                                 {"converged", ba.converged},
                                 {"iterations", ba.iterations},
                                 {"adjusted_points", ba.adjusted_points},
                                 {"initial_rms_px", ba.initial_rms_px},
                                 {"final_rms_px", ba.final_rms_px},
                                 {"message", ba.message}};
  report["keyframe_a_features_precomputed"] = r.keyframe_a_features_precomputed;
  if (!r.keyframe_b_tries.empty()) {
    json tries = json::array();
    for (const EntryReport::BTry& t : r.keyframe_b_tries) {
      tries.push_back({{"frame", t.frame},
                       {"seconds_after_a", t.seconds_after_a},
                       {"gate_parallax_deg", t.gate_parallax_deg},
                       {"tracks", t.tracks},
                       {"after_lost_track", t.after_lost_track},
                       {"accepted", t.accepted},
                       {"failure", t.failure},
                       {"reason", t.reason}});
    }
    report["keyframe_b_tries"] = tries;
  }
  report["keyframes"] = {{"a", KeyframeJson(r.keyframe_a)}, {"b", KeyframeJson(r.keyframe_b)}};
  report["camera"] = CameraJson(r.camera);
  const Eigen::Matrix3d& rot = r.relative_pose.rotation;
  const Eigen::Vector4d& q = r.relative_pose.quaternion_wxyz;
  const Eigen::Vector3d& t = r.relative_pose.translation;
  report["relative_pose"] = {{"convention", r.relative_pose.convention},
                             {"rotation",
                              {{rot(0, 0), rot(0, 1), rot(0, 2)},
                               {rot(1, 0), rot(1, 1), rot(1, 2)},
                               {rot(2, 0), rot(2, 1), rot(2, 2)}}},
                             {"quaternion_wxyz", {q(0), q(1), q(2), q(3)}},
                             {"translation", {t.x(), t.y(), t.z()}}};
  report["scale"] = ScaleJson(r.scale);
  const auto& n = r.counts;
  report["counts"] = {{"features_a", n.features_a},
                      {"features_b", n.features_b},
                      {"matches", n.matches},
                      {"gate_tracks", n.gate_tracks},
                      {"gate_tracks_used", n.gate_tracks_used},
                      {"gate_track_inliers", n.gate_track_inliers},
                      {"inliers", n.inliers},
                      {"points", n.points},
                      {"mesh_vertices", n.mesh_vertices},
                      {"mesh_triangles", n.mesh_triangles},
                      {"mesh_dropped_depth_discontinuity", n.mesh_dropped_depth_discontinuity},
                      {"mesh_dropped_grazing_angle", n.mesh_dropped_grazing_angle}};
  const auto& m = r.meshing;
  report["meshing"] = {{"mode", m.mode},
                       {"dense_valid_fraction", m.dense_valid_fraction},
                       {"dense_planes", m.dense_planes},
                       {"dense_views_between", m.dense_views_between},
                       {"dense_views_before_a", m.dense_views_before_a},
                       {"dense_views_left_out", m.dense_views_left_out},
                       {"dense_dropped_no_depth", m.dense_dropped_no_depth},
                       {"dense_dropped_bridging", m.dense_dropped_bridging},
                       {"dense_dropped_discontinuity", m.dense_dropped_discontinuity},
                       {"dense_fallback_reason", m.dense_fallback_reason},
                       {"voxel_size", m.voxel_size},
                       {"occupied_cells", m.occupied_cells},
                       {"kept_cells", m.kept_cells},
                       {"delaunay_triangles", m.delaunay_triangles},
                       {"max_depth_ratio", m.max_depth_ratio},
                       {"max_grazing_angle_deg", m.max_grazing_angle_deg},
                       {"min_points_per_cell", m.min_points_per_cell},
                       {"voxel_vertex", m.voxel_vertex}};
  report["quality"] = {{"median_triangulation_angle_deg", r.quality.median_triangulation_angle_deg},
                       {"reprojection_rms_px", r.quality.reprojection_rms_px}};
  const auto& ts = r.timings_s;
  report["timings_s"] = {
      {"features_a", ts.features_a},  {"features_b", ts.features_b}, {"matching", ts.matching},
      {"geometry", ts.geometry},      {"dense", ts.dense},           {"meshing", ts.meshing},
      {"total_recon", ts.total_recon}};
  if (ts.preview) report["timings_s"]["preview"] = *ts.preview;
  if (ts.encode) report["timings_s"]["encode"] = *ts.encode;
  if (r.preview) {
    if (r.preview->error.empty()) {
      report["preview"] = {{"file", r.preview->file}, {"renderer", r.preview->renderer}};
    } else {
      report["preview"] = {{"error", r.preview->error}};
    }
  }
  return report;
}

std::string FormatEntryReport(const EntryReport& report) {
  return JsonText(ToJson(report), 2) + "\n";
}

json ToJson(const WalkReport& r) {
  json report;
  report["kind"] = "walk";
  report["schema_version"] = r.schema_version;
  report["monomesh_version"] = r.monomesh_version;
  report["boot_id"] = r.boot_id;
  report["success"] = r.success;
  report["failure_reason"] = r.failure_reason;
  report["stop_reason"] = r.stop_reason;
  report["frames"] = r.frames;
  report["map_segment"] = r.map_segment;
  report["camera"] = CameraJson(r.camera);
  report["scale"] = ScaleJson(r.scale);
  json keyframes = json::array();
  for (const WalkReport::Keyframe& k : r.keyframes) {
    keyframes.push_back(
        {{"index", k.index},
         {"keyframe", KeyframeJson(k.info)},
         {"image", k.image},
         {"segment", k.segment},
         {"registered", k.registered},
         {"failure", k.failure},
         {"relocalized_to", k.relocalized_to},
         {"merged_segment", k.merged_segment},
         {"loop_to", k.loop_to},
         {"matches", k.matches},
         {"pnp_inliers", k.pnp_inliers},
         {"new_points", k.new_points},
         {"bundle_rms_px", k.bundle_rms_px},
         {"seconds", k.seconds},
         {"cam_from_segment",
          {{"convention", "X_cam = R X_segment + t"},
           {"quaternion_wxyz",
            {k.quaternion_wxyz[0], k.quaternion_wxyz[1], k.quaternion_wxyz[2],
             k.quaternion_wxyz[3]}},
           {"translation", {k.translation.x(), k.translation.y(), k.translation.z()}}}}});
  }
  report["keyframes"] = keyframes;
  json segments = json::array();
  for (const WalkReport::Segment& s : r.segments) {
    segments.push_back({{"segment", s.segment},
                        {"keyframes", s.keyframes},
                        {"registered", s.registered},
                        {"first_keyframe", s.first_keyframe}});
  }
  report["segments"] = segments;
  const auto& n = r.counts;
  report["counts"] = {{"keyframes", n.keyframes},
                      {"registered", n.registered},
                      {"segments", n.segments},
                      {"relocalizations", n.relocalizations},
                      {"merges", n.merges},
                      {"loop_closures", n.loop_closures},
                      {"lost_keyframes", n.lost_keyframes},
                      {"points", n.points},
                      {"mesh_parts", n.mesh_parts},
                      {"mesh_dense_parts", n.mesh_dense_parts},
                      {"mesh_vertices", n.mesh_vertices},
                      {"mesh_triangles", n.mesh_triangles},
                      {"mesh_dropped_overlap", n.mesh_dropped_overlap}};
  const auto& f = r.refinement;
  report["refinement"] = {{"ran", f.ran},
                          {"skipped", f.skipped},
                          {"pairs", f.pairs},
                          {"verified_pairs", f.verified_pairs},
                          {"points", f.points},
                          {"observations", f.observations},
                          {"rms_px", f.rms_px}};
  const auto& t = r.timings_s;
  report["timings_s"] = {{"walk", t.walk},
                         {"registration_median", t.registration_median},
                         {"registration_total", t.registration_total},
                         {"refinement", t.refinement},
                         {"mesh", t.mesh},
                         {"preview", t.preview},
                         {"encode", t.encode}};
  if (r.preview) {
    report["preview"] = {
        {"file", r.preview->file}, {"renderer", r.preview->renderer}, {"error", r.preview->error}};
  }
  return report;
}

std::string FormatWalkReport(const WalkReport& report) {
  return JsonText(ToJson(report), 2) + "\n";
}

}  // namespace mm
