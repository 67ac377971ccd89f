// report.json's reading: FromJson of a pair's report and of a walk's, and ReportKind. Keys
// that are absent keep their defaults; a value the report's types cannot hold is refused with
// the field named.
#include "entry/report.h"

#include <Eigen/Core>
#include <algorithm>
#include <cstdint>
#include <limits>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <type_traits>

#include "base/checked_number.h"

namespace mm {
namespace {

using json = nlohmann::json;

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

std::string ReportKind(const json& j) {
  if (j.is_object()) {
    const auto it = j.find("kind");
    if (it != j.end() && it->is_string() && it->get<std::string>() == "walk") return "walk";
  }
  return "pair";
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
        Read(kj, "relocalized_to", &k.relocalized_to);
        Read(kj, "merged_segment", &k.merged_segment);
        Read(kj, "loop_to", &k.loop_to);
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
    Read(n, "relocalizations", &r.counts.relocalizations);
    Read(n, "merges", &r.counts.merges);
    Read(n, "loop_closures", &r.counts.loop_closures);
    Read(n, "lost_keyframes", &r.counts.lost_keyframes);
    Read(n, "points", &r.counts.points);
    Read(n, "mesh_parts", &r.counts.mesh_parts);
    Read(n, "mesh_dense_parts", &r.counts.mesh_dense_parts);
    Read(n, "mesh_vertices", &r.counts.mesh_vertices);
    Read(n, "mesh_triangles", &r.counts.mesh_triangles);
    Read(n, "mesh_dropped_overlap", &r.counts.mesh_dropped_overlap);
    const json& f = Object(j, "refinement");
    Read(f, "ran", &r.refinement.ran);
    Read(f, "skipped", &r.refinement.skipped);
    Read(f, "pairs", &r.refinement.pairs);
    Read(f, "verified_pairs", &r.refinement.verified_pairs);
    Read(f, "points", &r.refinement.points);
    Read(f, "observations", &r.refinement.observations);
    Read(f, "rms_px", &r.refinement.rms_px);
    const json& t = Object(j, "timings_s");
    Read(t, "walk", &r.timings_s.walk);
    Read(t, "refinement", &r.timings_s.refinement);
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

}  // namespace mm
