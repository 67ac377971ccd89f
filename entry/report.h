#pragma once
// report.json of a spool entry as a type: what one pair job found (keyframes, relative pose
// cam_b_from_cam_a, counts, quality, timings). MakeEntryReport fills it from the
// reconstruction; ToJson writes report.json and FromJson reads it back, so readers (eval, the
// tests, the web view) never spell the keys.
//
// Schema: `schema_version` (kEntryReportSchemaVersion) names the layout; a report without it
// was written before the field existed and has layout 1. FromJson refuses a newer version.
// Keys are sorted (nlohmann::json objects); numbers keep their type (counts are integers,
// figures doubles).
//
// Thread-safety: plain data and pure functions; reentrant.

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <nlohmann/json_fwd.hpp>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "calib/camera_model.h"
#include "recon/pipeline.h"
#include "scale/metric_scale.h"
#include "session/capture_session.h"

namespace mm {

/// 2: `scale` is an object. 3: keyframes carry `capture_realtime_ns`, the report `boot_id`.
/// docs/report_schema.md documents every field.
inline constexpr int kEntryReportSchemaVersion = 3;

/// Where a keyframe came from, for the report.
struct KeyframeInfo {
  uint64_t sequence = 0;
  double source_time_s = 0.0;
  int64_t capture_time_ns = 0;      ///< CLOCK_MONOTONIC (of the boot `boot_id` names).
  int64_t capture_realtime_ns = 0;  ///< The same instant on CLOCK_REALTIME (0: unknown).
  std::string source;
};

struct EntryReport {
  int schema_version = kEntryReportSchemaVersion;
  std::string monomesh_version;
  /// /proc/sys/kernel/random/boot_id of the boot whose CLOCK_MONOTONIC the keyframes' capture
  /// times are on ("" when unknown).
  std::string boot_id;
  bool success = false;
  std::string failure_reason;

  struct PairClassification {
    std::string kind;
    std::string explanation;
    int f_inliers = 0;
    int h_inliers = 0;
    double median_flow_px = 0.0;
  } pair_classification;

  struct Ransac {
    int iterations = 0;
    int required_iterations = 0;
    uint64_t inliers = 0;
    double inlier_rms_px = 0.0;
  } ransac_f;

  struct BundleAdjustment {
    bool ran = false;
    bool converged = false;
    int iterations = 0;
    int adjusted_points = 0;
    double initial_rms_px = 0.0;
    double final_rms_px = 0.0;
    std::string message;
  } bundle_adjustment;

  bool keyframe_a_features_precomputed = false;
  /// Every keyframe B this capture handed to the reconstruction, the last being this entry's;
  /// the refused ones say why (empty for a pair reconstructed outside a capture).
  struct BTry {
    uint64_t frame = 0;
    double seconds_after_a = 0.0;
    double gate_parallax_deg = 0.0;
    int tracks = 0;
    bool after_lost_track = false;  ///< Handed over when the gate's tracks broke.
    bool accepted = false;
    std::string failure;  ///< TwoViewFailureName.
    std::string reason;
  };
  std::vector<BTry> keyframe_b_tries;
  KeyframeInfo keyframe_a;
  KeyframeInfo keyframe_b;

  /// The camera of the undistorted frames.
  struct Camera {
    int width = 0;
    int height = 0;
    Eigen::Vector2d fc = Eigen::Vector2d::Zero();
    Eigen::Vector2d cc = Eigen::Vector2d::Zero();
    double alpha_c = 0.0;
    std::array<double, 5> kc{};
  } camera;

  /// cam_b_from_cam_a: X_b = R X_a + t; |t| = 1 unscaled, the baseline in metres scaled.
  struct RelativePose {
    std::string convention = "cam_b_from_cam_a: X_b = R X_a + t";
    Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();
    Eigen::Vector4d quaternion_wxyz = Eigen::Vector4d(1, 0, 0, 0);
    Eigen::Vector3d translation = Eigen::Vector3d::Zero();
  } relative_pose;

  /// The entry's units (scale/metric_scale.h): metres when a source scaled it (every length
  /// in the entry and its files is then in metres), else the baseline is the unit.
  struct Scale {
    std::string source = "none";     ///< ScaleSourceName of the source used.
    std::string units = "baseline";  ///< "metres" or "baseline".
    double metres_per_unit = 1.0;    ///< Applied to the reconstruction (1 when unscaled).
    double uncertainty_rel = 0.0;
    double odometry_metres_per_unit = 0.0;  ///< Each source's figure (0: none).
    double floor_metres_per_unit = 0.0;
    std::string why_not;  ///< Why unscaled, or why a source was passed over.
  } scale;

  struct Counts {
    int features_a = 0;
    int features_b = 0;
    int matches = 0;
    int gate_tracks = 0;         ///< The keyframe gate's tracks from A to B given.
    int gate_tracks_used = 0;    ///< Of those, not duplicates of a SIFT match.
    int gate_track_inliers = 0;  ///< Epipolar inliers among the tracks used.
    int inliers = 0;
    uint64_t points = 0;
    uint64_t mesh_vertices = 0;
    uint64_t mesh_triangles = 0;
    int mesh_dropped_depth_discontinuity = 0;
    int mesh_dropped_grazing_angle = 0;
  } counts;

  struct Meshing {
    std::string mode = "sparse";  ///< The mesh the entry got: "dense" or "sparse".
    /// Dense mode: the share of A with a dense depth, the sweep's planes, the dense mesh's
    /// dropped triangles, and why the entry fell back to the sparse mesh (empty: it did not).
    double dense_valid_fraction = 0.0;
    int dense_planes = 0;
    /// Source views the sweep used beside B (frames between A and B, and of them, before A),
    /// and why the others were left out.
    int dense_views_between = 0;
    int dense_views_before_a = 0;
    std::string dense_views_left_out;
    int dense_dropped_no_depth = 0;
    int dense_dropped_bridging = 0;
    int dense_dropped_discontinuity = 0;
    std::string dense_fallback_reason;
    double voxel_size = 0.0;
    int occupied_cells = 0;
    int kept_cells = 0;
    int delaunay_triangles = 0;
    double max_depth_ratio = 0.0;
    double max_grazing_angle_deg = 0.0;
    int min_points_per_cell = 0;
    std::string voxel_vertex;
  } meshing;

  struct Quality {
    double median_triangulation_angle_deg = 0.0;
    double reprojection_rms_px = 0.0;
  } quality;

  struct Timings {
    double features_a = 0.0;
    double features_b = 0.0;
    double matching = 0.0;
    double geometry = 0.0;
    double dense = 0.0;
    double meshing = 0.0;
    double total_recon = 0.0;
    std::optional<double> preview;  ///< Only for an entry that was encoded.
    std::optional<double> encode;
  } timings_s;

  /// preview.png: the file and the GL renderer, or why there is none. Absent when the
  /// reconstruction failed (nothing was encoded).
  struct Preview {
    std::string file;
    std::string renderer;
    std::string error;  ///< Non-empty: no preview.
  };
  std::optional<Preview> preview;
};

/// The report of a reconstructed (or failed) pair; preview and the encode timings are left for
/// the encoder (EncodeEntry).
/// `tries`: the capture's B tries, the last being this pair (its verdict is taken from `recon`).
EntryReport MakeEntryReport(const PairReconstruction& recon, const KeyframeInfo& a,
                            const KeyframeInfo& b, const BouguetCamera& camera,
                            const PairOptions& options, bool features_a_precomputed,
                            std::span<const KeyframeBTry> tries = {},
                            const ScaleEstimate& scale = {});

/// The report's `scale` for an estimate (units "metres" when it scaled, else "baseline").
EntryReport::Scale ReportScale(const ScaleEstimate& scale);

nlohmann::json ToJson(const EntryReport& report);

/// Reads a report; keys that are absent keep their defaults (a report may be partial, e.g. a
/// failed pair's). Returns "" or what is wrong (a key of the wrong type, a newer schema).
[[nodiscard]] std::string FromJson(const nlohmann::json& j, EntryReport* report);

/// A few lines for people and scripts (as Ceres' Summary::BriefReport): `key value` per line,
/// e.g. "success true", "points 731", "mesh_vertices 603", "mesh_triangles 1060",
/// "inliers 736", "gate_track_inliers 235", "b_tries 1", "total_recon_s 0.18", "failure ...".
std::string BriefReport(const EntryReport& report);

/// report.json's bytes: ToJson, two-space indent, a final newline.
std::string FormatEntryReport(const EntryReport& report);

/// report.json of a walk entry (`"kind": "walk"`): the walk's keyframes with their poses in
/// their segment's frame, the segments, the map's counts, timings and units. A pair's FromJson
/// refuses it (and this one a pair's), so each reader knows which entry it holds.
inline constexpr int kWalkReportSchemaVersion = 1;
struct WalkReport {
  int schema_version = kWalkReportSchemaVersion;
  std::string monomesh_version;
  std::string boot_id;
  bool success = false;  ///< The map has a segment of >= 2 registered keyframes.
  std::string failure_reason;
  /// Why the walk ended: "operator" (walk stop), "timeout", "keyframe limit", "camera lost",
  /// "daemon stopping".
  std::string stop_reason;
  uint64_t frames = 0;   ///< Frames the walk saw.
  int map_segment = -1;  ///< The segment the map files are of (the largest).
  EntryReport::Camera camera;
  EntryReport::Scale scale;
  struct Keyframe {
    int index = 0;
    KeyframeInfo info;
    std::string image;  ///< Its file in the entry.
    int segment = 0;
    bool registered = false;
    std::string failure;      ///< Lost, or a new segment after lost keyframes: why.
    int relocalized_to = -1;  ///< Relocalised against this keyframe (-1: not).
    int merged_segment = -1;  ///< Merged that segment into its own (-1: none).
    int loop_to = -1;         ///< Closed a loop with this keyframe (-1: none).
    int matches = 0;
    int pnp_inliers = 0;
    int new_points = 0;
    double bundle_rms_px = 0.0;
    double seconds = 0.0;  ///< Registration (SIFT, matching, pose, local BA).
    /// cam_from_segment: X_cam = R X_segment + t (valid when registered).
    Eigen::Vector4d quaternion_wxyz = Eigen::Vector4d(1, 0, 0, 0);
    Eigen::Vector3d translation = Eigen::Vector3d::Zero();
  };
  std::vector<Keyframe> keyframes;
  struct Segment {
    int segment = 0;
    int keyframes = 0;
    int registered = 0;
    int first_keyframe = 0;
  };
  std::vector<Segment> segments;
  struct Counts {
    int keyframes = 0;
    int registered = 0;
    int segments = 0;  ///< With a registered keyframe (merged ones count once).
    int relocalizations = 0;
    int merges = 0;  ///< Segments merged into another.
    int loop_closures = 0;
    int lost_keyframes = 0;  ///< Neither registered nor relocalised.
    int points = 0;          ///< Of the map segment.
    int mesh_parts = 0;
    int mesh_dense_parts = 0;
    int mesh_vertices = 0;
    int mesh_triangles = 0;
    int mesh_dropped_overlap = 0;
  } counts;
  /// The map's refinement after the walk (map/walk_refine.h): tracks across the keyframes.
  struct Refinement {
    bool ran = false;
    std::string skipped;  ///< Why not, when it did not run.
    int pairs = 0;        ///< Pairs of keyframes matched,
    int verified_pairs = 0;  ///< of them verified by a fundamental matrix.
    int points = 0;          ///< Points of those tracks in the adjustment,
    int observations = 0;    ///< and their observations.
    double rms_px = 0.0;     ///< The adjustment's final RMS (with the walk's own points).
  } refinement;
  struct Timings {
    double walk = 0.0;  ///< From walk start to stop.
    double registration_median = 0.0;
    double registration_total = 0.0;
    double refinement = 0.0;  ///< After the walk, before the mesh.
    double mesh = 0.0;
    double preview = 0.0;
    double encode = 0.0;
  } timings_s;
  std::optional<EntryReport::Preview> preview;
};

nlohmann::json ToJson(const WalkReport& report);
/// Reads a walk report. Returns "" or what is wrong (naming the field).
std::string FromJson(const nlohmann::json& j, WalkReport* report);
std::string FormatWalkReport(const WalkReport& report);
/// The kind of report.json: "walk" or "pair" (a report without `kind`).
std::string ReportKind(const nlohmann::json& j);

}  // namespace mm
