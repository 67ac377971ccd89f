#include "entry/report.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cstdint>
#include <limits>
#include <nlohmann/json.hpp>
#include <optional>
#include <type_traits>

#include "base/checked_number.h"
#include "base/version.h"
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

// A field whose value the report's types cannot hold (its text names the field).
struct FieldError {
  std::string what;
};

// j as an integer of type T, or a FieldError naming `key`. nlohmann's own conversion casts a
// floating value to the integer type unchecked (6.9e19 to int is undefined behaviour) and wraps
// an unsigned one; CheckedNumber refuses both.
template <typename T>
T Integer(const json& j, const char* key) {
  ParsedNumber parsed;
  if (j.is_number_unsigned()) {
    const auto u = j.get<uint64_t>();
    parsed = u <= static_cast<uint64_t>(std::numeric_limits<int64_t>::max())
                 ? ParsedNumber(static_cast<int64_t>(u))
                 : ParsedNumber(static_cast<double>(u));
  } else if (j.is_number_integer()) {
    parsed = j.get<int64_t>();
  } else if (j.is_number_float()) {
    parsed = j.get<double>();
  } else {
    throw FieldError{std::string(key) + ": expected an integer, got " + j.type_name()};
  }
  // The largest a field takes is what both T and int64_t hold (CheckedNumber compares in int64).
  const NumberRange<T> range{
      std::numeric_limits<T>::lowest(),
      static_cast<T>(
          std::min<uint64_t>(std::numeric_limits<T>::max(), std::numeric_limits<int64_t>::max()))};
  std::string problem;
  const std::optional<T> value = CheckedNumber<T>(parsed, range, &problem);
  if (!value) throw FieldError{std::string(key) + ": " + problem};
  return *value;
}

// "reason; reason" of the source views the dense stage left out.
std::string JoinLeftOut(const std::vector<std::string>& reasons) {
  std::string out;
  for (const std::string& reason : reasons) out += (out.empty() ? "" : "; ") + reason;
  return out;
}

// Sets *out from j[key] when the key is there (nlohmann throws on a type mismatch; an integer
// field goes through Integer).
template <typename T>
void Read(const json& j, const char* key, T* out) {
  const auto it = j.find(key);
  if (it == j.end()) return;
  if constexpr (std::is_integral_v<T> && !std::is_same_v<T, bool>) {
    *out = Integer<T>(*it, key);
  } else {
    it->get_to(*out);
  }
}

// The object j[key], or an empty object when absent.
const json& Object(const json& j, const char* key) {
  static const json empty = json::object();
  const auto it = j.find(key);
  return it == j.end() ? empty : *it;
}

template <typename Derived>
void ReadVector(const json& j, const char* key, Eigen::MatrixBase<Derived>* out) {
  const auto it = j.find(key);
  if (it == j.end()) return;
  for (Eigen::Index i = 0; i < out->size(); ++i) (*out)(i) = it->at(i).template get<double>();
}

json CameraJson(const EntryReport::Camera& cam) {
  return {{"image_size", {cam.width, cam.height}},
          {"fc", {cam.fc.x(), cam.fc.y()}},
          {"cc", {cam.cc.x(), cam.cc.y()}},
          {"alpha_c", cam.alpha_c},
          {"kc", cam.kc}};
}

void ReadCamera(const json& cam, EntryReport::Camera* out) {
  if (const auto it = cam.find("image_size"); it != cam.end()) {
    out->width = Integer<int>(it->at(0), "image_size");
    out->height = Integer<int>(it->at(1), "image_size");
  }
  ReadVector(cam, "fc", &out->fc);
  ReadVector(cam, "cc", &out->cc);
  Read(cam, "alpha_c", &out->alpha_c);
  Read(cam, "kc", &out->kc);
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

// Layout 1 had a note string for `scale` (always up to scale): the defaults say the same.
void ReadScale(const json& report, EntryReport::Scale* out) {
  const auto it = report.find("scale");
  if (it == report.end() || !it->is_object()) return;
  const json& scale = *it;
  Read(scale, "source", &out->source);
  Read(scale, "units", &out->units);
  Read(scale, "metres_per_unit", &out->metres_per_unit);
  Read(scale, "uncertainty_rel", &out->uncertainty_rel);
  Read(scale, "odometry_metres_per_unit", &out->odometry_metres_per_unit);
  Read(scale, "floor_metres_per_unit", &out->floor_metres_per_unit);
  Read(scale, "why_not", &out->why_not);
}

void ReadKeyframe(const json& j, KeyframeInfo* k) {
  Read(j, "sequence", &k->sequence);
  Read(j, "source_time_s", &k->source_time_s);
  Read(j, "capture_time_ns", &k->capture_time_ns);
  Read(j, "capture_realtime_ns", &k->capture_realtime_ns);
  Read(j, "source", &k->source);
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

std::string FromJson(const json& j, EntryReport* out) {
  EntryReport r;
  try {
    if (!j.is_object()) return "a report is a JSON object";
    if (ReportKind(j) != "pair") return "a walk's report, not a pair's (kind: walk)";
    r.schema_version = 1;  // Written before the field existed.
    Read(j, "schema_version", &r.schema_version);
    if (r.schema_version > kEntryReportSchemaVersion) {
      return "report schema " + std::to_string(r.schema_version) + " is newer than " +
             std::to_string(kEntryReportSchemaVersion);
    }
    Read(j, "monomesh_version", &r.monomesh_version);
    Read(j, "boot_id", &r.boot_id);
    Read(j, "success", &r.success);
    Read(j, "failure_reason", &r.failure_reason);
    const json& c = Object(j, "pair_classification");
    Read(c, "kind", &r.pair_classification.kind);
    Read(c, "explanation", &r.pair_classification.explanation);
    Read(c, "f_inliers", &r.pair_classification.f_inliers);
    Read(c, "h_inliers", &r.pair_classification.h_inliers);
    Read(c, "median_flow_px", &r.pair_classification.median_flow_px);
    const json& f = Object(j, "ransac_f");
    Read(f, "iterations", &r.ransac_f.iterations);
    Read(f, "required_iterations", &r.ransac_f.required_iterations);
    Read(f, "inliers", &r.ransac_f.inliers);
    Read(f, "inlier_rms_px", &r.ransac_f.inlier_rms_px);
    const json& ba = Object(j, "bundle_adjustment");
    Read(ba, "ran", &r.bundle_adjustment.ran);
    Read(ba, "converged", &r.bundle_adjustment.converged);
    Read(ba, "iterations", &r.bundle_adjustment.iterations);
    Read(ba, "adjusted_points", &r.bundle_adjustment.adjusted_points);
    Read(ba, "initial_rms_px", &r.bundle_adjustment.initial_rms_px);
    Read(ba, "final_rms_px", &r.bundle_adjustment.final_rms_px);
    Read(ba, "message", &r.bundle_adjustment.message);
    Read(j, "keyframe_a_features_precomputed", &r.keyframe_a_features_precomputed);
    if (const auto it = j.find("keyframe_b_tries"); it != j.end()) {
      for (const json& t : *it) {
        EntryReport::BTry b;
        Read(t, "frame", &b.frame);
        Read(t, "seconds_after_a", &b.seconds_after_a);
        Read(t, "gate_parallax_deg", &b.gate_parallax_deg);
        Read(t, "tracks", &b.tracks);
        Read(t, "after_lost_track", &b.after_lost_track);
        Read(t, "accepted", &b.accepted);
        Read(t, "failure", &b.failure);
        Read(t, "reason", &b.reason);
        r.keyframe_b_tries.push_back(std::move(b));
      }
    }
    const json& k = Object(j, "keyframes");
    ReadKeyframe(Object(k, "a"), &r.keyframe_a);
    ReadKeyframe(Object(k, "b"), &r.keyframe_b);
    ReadCamera(Object(j, "camera"), &r.camera);
    const json& pose = Object(j, "relative_pose");
    Read(pose, "convention", &r.relative_pose.convention);
    if (const auto it = pose.find("rotation"); it != pose.end()) {
      for (int row = 0; row < 3; ++row) {
        for (int col = 0; col < 3; ++col) {
          r.relative_pose.rotation(row, col) = it->at(row).at(col).get<double>();
        }
      }
    }
    ReadVector(pose, "quaternion_wxyz", &r.relative_pose.quaternion_wxyz);
    ReadVector(pose, "translation", &r.relative_pose.translation);
    ReadScale(j, &r.scale);
    const json& n = Object(j, "counts");
    Read(n, "features_a", &r.counts.features_a);
    Read(n, "features_b", &r.counts.features_b);
    Read(n, "matches", &r.counts.matches);
    Read(n, "gate_tracks", &r.counts.gate_tracks);
    Read(n, "gate_tracks_used", &r.counts.gate_tracks_used);
    Read(n, "gate_track_inliers", &r.counts.gate_track_inliers);
    Read(n, "inliers", &r.counts.inliers);
    Read(n, "points", &r.counts.points);
    Read(n, "mesh_vertices", &r.counts.mesh_vertices);
    Read(n, "mesh_triangles", &r.counts.mesh_triangles);
    Read(n, "mesh_dropped_depth_discontinuity", &r.counts.mesh_dropped_depth_discontinuity);
    Read(n, "mesh_dropped_grazing_angle", &r.counts.mesh_dropped_grazing_angle);
    const json& m = Object(j, "meshing");
    Read(m, "mode", &r.meshing.mode);
    Read(m, "dense_valid_fraction", &r.meshing.dense_valid_fraction);
    Read(m, "dense_planes", &r.meshing.dense_planes);
    Read(m, "dense_views_between", &r.meshing.dense_views_between);
    Read(m, "dense_views_before_a", &r.meshing.dense_views_before_a);
    Read(m, "dense_views_left_out", &r.meshing.dense_views_left_out);
    Read(m, "dense_dropped_no_depth", &r.meshing.dense_dropped_no_depth);
    Read(m, "dense_dropped_bridging", &r.meshing.dense_dropped_bridging);
    Read(m, "dense_dropped_discontinuity", &r.meshing.dense_dropped_discontinuity);
    Read(m, "dense_fallback_reason", &r.meshing.dense_fallback_reason);
    Read(m, "voxel_size", &r.meshing.voxel_size);
    Read(m, "occupied_cells", &r.meshing.occupied_cells);
    Read(m, "kept_cells", &r.meshing.kept_cells);
    Read(m, "delaunay_triangles", &r.meshing.delaunay_triangles);
    Read(m, "max_depth_ratio", &r.meshing.max_depth_ratio);
    Read(m, "max_grazing_angle_deg", &r.meshing.max_grazing_angle_deg);
    Read(m, "min_points_per_cell", &r.meshing.min_points_per_cell);
    Read(m, "voxel_vertex", &r.meshing.voxel_vertex);
    const json& qj = Object(j, "quality");
    Read(qj, "median_triangulation_angle_deg", &r.quality.median_triangulation_angle_deg);
    Read(qj, "reprojection_rms_px", &r.quality.reprojection_rms_px);
    const json& ts = Object(j, "timings_s");
    Read(ts, "features_a", &r.timings_s.features_a);
    Read(ts, "features_b", &r.timings_s.features_b);
    Read(ts, "matching", &r.timings_s.matching);
    Read(ts, "geometry", &r.timings_s.geometry);
    Read(ts, "dense", &r.timings_s.dense);
    Read(ts, "meshing", &r.timings_s.meshing);
    Read(ts, "total_recon", &r.timings_s.total_recon);
    if (ts.contains("preview")) r.timings_s.preview = ts.at("preview").get<double>();
    if (ts.contains("encode")) r.timings_s.encode = ts.at("encode").get<double>();
    if (j.contains("preview")) {
      const json& p = j.at("preview");
      EntryReport::Preview preview;
      Read(p, "file", &preview.file);
      Read(p, "renderer", &preview.renderer);
      Read(p, "error", &preview.error);
      r.preview = preview;
    }
  } catch (const json::exception& e) {
    return e.what();
  } catch (const FieldError& e) {
    return e.what;
  }
  *out = std::move(r);
  return {};
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

std::string FormatEntryReport(const EntryReport& report) {
  return JsonText(ToJson(report), 2) + "\n";
}

std::string ReportKind(const json& j) {
  if (j.is_object()) {
    const auto it = j.find("kind");
    if (it != j.end() && it->is_string() && it->get<std::string>() == "walk") return "walk";
  }
  return "pair";
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
                      {"points", n.points},
                      {"mesh_parts", n.mesh_parts},
                      {"mesh_dense_parts", n.mesh_dense_parts},
                      {"mesh_vertices", n.mesh_vertices},
                      {"mesh_triangles", n.mesh_triangles},
                      {"mesh_dropped_overlap", n.mesh_dropped_overlap}};
  const auto& t = r.timings_s;
  report["timings_s"] = {{"walk", t.walk},
                         {"registration_median", t.registration_median},
                         {"registration_total", t.registration_total},
                         {"mesh", t.mesh},
                         {"preview", t.preview},
                         {"encode", t.encode}};
  if (r.preview) {
    report["preview"] = {
        {"file", r.preview->file}, {"renderer", r.preview->renderer}, {"error", r.preview->error}};
  }
  return report;
}

std::string FromJson(const json& j, WalkReport* out) {
  WalkReport r;
  try {
    if (!j.is_object()) return "a report is a JSON object";
    if (ReportKind(j) != "walk") return "a pair's report, not a walk's (no kind: walk)";
    Read(j, "schema_version", &r.schema_version);
    if (r.schema_version > kWalkReportSchemaVersion) {
      return "walk report schema " + std::to_string(r.schema_version) + " is newer than " +
             std::to_string(kWalkReportSchemaVersion);
    }
    Read(j, "monomesh_version", &r.monomesh_version);
    Read(j, "boot_id", &r.boot_id);
    Read(j, "success", &r.success);
    Read(j, "failure_reason", &r.failure_reason);
    Read(j, "stop_reason", &r.stop_reason);
    Read(j, "frames", &r.frames);
    Read(j, "map_segment", &r.map_segment);
    ReadCamera(Object(j, "camera"), &r.camera);
    ReadScale(j, &r.scale);
    if (const auto it = j.find("keyframes"); it != j.end()) {
      if (!it->is_array()) return "keyframes: expected an array";
      for (const json& kj : *it) {
        if (!kj.is_object()) return "keyframes: expected objects";
        WalkReport::Keyframe k;
        Read(kj, "index", &k.index);
        ReadKeyframe(Object(kj, "keyframe"), &k.info);
        Read(kj, "image", &k.image);
        Read(kj, "segment", &k.segment);
        Read(kj, "registered", &k.registered);
        Read(kj, "failure", &k.failure);
        Read(kj, "matches", &k.matches);
        Read(kj, "pnp_inliers", &k.pnp_inliers);
        Read(kj, "new_points", &k.new_points);
        Read(kj, "bundle_rms_px", &k.bundle_rms_px);
        Read(kj, "seconds", &k.seconds);
        const json& pose = Object(kj, "cam_from_segment");
        ReadVector(pose, "quaternion_wxyz", &k.quaternion_wxyz);
        ReadVector(pose, "translation", &k.translation);
        r.keyframes.push_back(std::move(k));
      }
    }
    if (const auto it = j.find("segments"); it != j.end()) {
      if (!it->is_array()) return "segments: expected an array";
      for (const json& sj : *it) {
        if (!sj.is_object()) return "segments: expected objects";
        WalkReport::Segment s;
        Read(sj, "segment", &s.segment);
        Read(sj, "keyframes", &s.keyframes);
        Read(sj, "registered", &s.registered);
        Read(sj, "first_keyframe", &s.first_keyframe);
        r.segments.push_back(s);
      }
    }
    const json& n = Object(j, "counts");
    Read(n, "keyframes", &r.counts.keyframes);
    Read(n, "registered", &r.counts.registered);
    Read(n, "segments", &r.counts.segments);
    Read(n, "points", &r.counts.points);
    Read(n, "mesh_parts", &r.counts.mesh_parts);
    Read(n, "mesh_dense_parts", &r.counts.mesh_dense_parts);
    Read(n, "mesh_vertices", &r.counts.mesh_vertices);
    Read(n, "mesh_triangles", &r.counts.mesh_triangles);
    Read(n, "mesh_dropped_overlap", &r.counts.mesh_dropped_overlap);
    const json& t = Object(j, "timings_s");
    Read(t, "walk", &r.timings_s.walk);
    Read(t, "registration_median", &r.timings_s.registration_median);
    Read(t, "registration_total", &r.timings_s.registration_total);
    Read(t, "mesh", &r.timings_s.mesh);
    Read(t, "preview", &r.timings_s.preview);
    Read(t, "encode", &r.timings_s.encode);
    if (j.contains("preview")) {
      const json& p = Object(j, "preview");
      EntryReport::Preview preview;
      Read(p, "file", &preview.file);
      Read(p, "renderer", &preview.renderer);
      Read(p, "error", &preview.error);
      r.preview = preview;
    }
  } catch (const json::exception& e) {
    return e.what();
  } catch (const FieldError& e) {
    return e.what;
  }
  *out = std::move(r);
  return {};
}

std::string FormatWalkReport(const WalkReport& report) {
  return JsonText(ToJson(report), 2) + "\n";
}

}  // namespace mm
