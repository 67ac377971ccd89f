#include "entry/report.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

namespace mm {
namespace {

using json = nlohmann::json;

EntryReport Filled() {
  EntryReport r;
  r.monomesh_version = "0.1.0";
  r.success = true;
  r.pair_classification = {.kind = "general",
                           .explanation = "F explains the pair",
                           .f_inliers = 300,
                           .h_inliers = 120,
                           .median_flow_px = 14.25};
  r.ransac_f = {.iterations = 80, .required_iterations = 41, .inliers = 300, .inlier_rms_px = 0.4};
  r.bundle_adjustment = {.ran = true,
                         .converged = true,
                         .iterations = 7,
                         .adjusted_points = 280,
                         .initial_rms_px = 0.5,
                         .final_rms_px = 0.3,
                         .message = "CONVERGENCE"};
  r.boot_id = "0f6c1c4e-5a1d-4c8b-9d59-2b7e3f1a9c10";
  r.keyframe_a = {.sequence = 3,
                  .source_time_s = 100.25,
                  .capture_time_ns = 17,
                  .capture_realtime_ns = 1'764'640'000'000'000'017,
                  .source = "a.png"};
  r.keyframe_b = {.sequence = 9,
                  .source_time_s = 101.5,
                  .capture_time_ns = 42,
                  .capture_realtime_ns = 1'764'640'000'000'000'042,
                  .source = "b.png"};
  r.camera = {.width = 640,
              .height = 480,
              .fc = {535.4, 539.2},
              .cc = {320.1, 247.6},
              .alpha_c = 0.0,
              .kc = {0.1, -0.2, 0, 0, 0.01}};
  r.relative_pose.rotation << 0, -1, 0, 1, 0, 0, 0, 0, 1;
  r.relative_pose.quaternion_wxyz = {0.5, 0.5, 0.5, 0.5};
  r.relative_pose.translation = {0.6, 0, 0.8};
  r.counts.points = 280;
  r.counts.mesh_vertices = 250;
  r.counts.gate_tracks = 200;
  r.counts.gate_tracks_used = 150;
  r.counts.gate_track_inliers = 140;
  r.keyframe_b_tries = {{.frame = 7,
                         .seconds_after_a = 0.2,
                         .gate_parallax_deg = 2.1,
                         .tracks = 210,
                         .accepted = false,
                         .failure = "no_parallax",
                         .reason = "too little parallax (median triangulation angle 0.9 deg)"},
                        {.frame = 9,
                         .seconds_after_a = 0.4,
                         .gate_parallax_deg = 2.8,
                         .tracks = 200,
                         .after_lost_track = true,
                         .accepted = true,
                         .failure = "none",
                         .reason = ""}};
  r.meshing.voxel_vertex = "cell_centre";
  r.timings_s.total_recon = 0.25;
  r.timings_s.preview = 0.05;
  r.timings_s.encode = 0.02;
  r.preview = EntryReport::Preview{.file = "preview.png", .renderer = "llvmpipe", .error = {}};
  return r;
}

TEST(EntryReport, RoundTripsThroughJson) {
  const json j = ToJson(Filled());
  EntryReport back;
  ASSERT_EQ(FromJson(j, &back), "");
  EXPECT_EQ(ToJson(back), j);
  EXPECT_EQ(back.keyframe_b.source, "b.png");
  EXPECT_EQ(back.relative_pose.rotation(0, 1), -1.0);
  EXPECT_EQ(back.counts.mesh_vertices, 250u);
  ASSERT_TRUE(back.preview.has_value());
  EXPECT_EQ(back.preview->renderer, "llvmpipe");
  EXPECT_EQ(j["schema_version"], kEntryReportSchemaVersion);
  EXPECT_EQ(kEntryReportSchemaVersion, 3);
  // Wall-clock capture times beside the monotonic ones, and the boot those are of.
  EXPECT_EQ(j["boot_id"], "0f6c1c4e-5a1d-4c8b-9d59-2b7e3f1a9c10");
  EXPECT_EQ(j["keyframes"]["a"]["capture_time_ns"], 17);
  EXPECT_EQ(j["keyframes"]["a"]["capture_realtime_ns"], 1'764'640'000'000'000'017);
  EXPECT_EQ(back.keyframe_b.capture_realtime_ns, 1'764'640'000'000'000'042);
  EXPECT_EQ(back.boot_id, Filled().boot_id);
  EXPECT_EQ(j["keyframes"]["a"]["source_time_s"], 100.25);
  EXPECT_EQ(j["camera"]["image_size"], json::array({640, 480}));
  ASSERT_EQ(back.keyframe_b_tries.size(), 2u);
  EXPECT_EQ(back.keyframe_b_tries[0].failure, "no_parallax");
  EXPECT_FALSE(back.keyframe_b_tries[0].accepted);
  EXPECT_TRUE(back.keyframe_b_tries[1].accepted);
  EXPECT_FALSE(back.keyframe_b_tries[0].after_lost_track);
  EXPECT_TRUE(back.keyframe_b_tries[1].after_lost_track);
  EXPECT_EQ(back.counts.gate_track_inliers, 140);
}

// A frame file name that is not UTF-8 (any byte string is a valid Linux name) made dump()
// throw, so every capture's report failed: it is written with U+FFFD and reads back.
TEST(WalkReport, RoundTripsAndEachReaderRefusesTheOtherKind) {
  WalkReport w;
  w.success = true;
  w.stop_reason = "operator";
  w.frames = 223;
  w.map_segment = 0;
  w.camera.width = 640;
  w.camera.height = 480;
  WalkReport::Keyframe k;
  k.index = 3;
  k.info.sequence = 77;
  k.info.source_time_s = 1002.5;
  k.image = "keyframe_0003.jpg";
  k.registered = true;
  k.pnp_inliers = 412;
  k.quaternion_wxyz = Eigen::Vector4d(0.9, 0.1, -0.2, 0.3).normalized();
  k.translation = Eigen::Vector3d(0.25, -0.5, 2.0);
  w.keyframes = {k};
  w.segments = {{.segment = 0, .keyframes = 1, .registered = 1, .first_keyframe = 3}};
  w.counts.keyframes = 1;
  w.counts.mesh_triangles = 8794;
  w.timings_s.registration_median = 0.141;
  w.refinement.ran = true;
  w.refinement.points = 3022;
  w.timings_s.refinement = 6.2;
  const json j = ToJson(w);
  EXPECT_EQ(ReportKind(j), "walk");
  WalkReport back;
  ASSERT_EQ(FromJson(j, &back), "");
  EXPECT_EQ(FormatWalkReport(back), FormatWalkReport(w));
  EXPECT_EQ(back.keyframes.at(0).info.sequence, 77u);
  EXPECT_TRUE(back.refinement.ran);
  EXPECT_EQ(back.refinement.points, 3022);
  EXPECT_NEAR((back.keyframes.at(0).translation - k.translation).norm(), 0.0, 1e-12);
  // A pair's reader refuses a walk's report by name, and the walk's reader a pair's.
  EntryReport pair;
  EXPECT_NE(FromJson(j, &pair).find("walk"), std::string::npos);
  EXPECT_NE(FromJson(ToJson(Filled()), &back), "");
  EXPECT_EQ(ReportKind(ToJson(Filled())), "pair");
}

TEST(EntryReport, NonUtf8FrameNameIsWrittenAsValidJson) {
  EntryReport r = Filled();
  r.keyframe_a.source = "rgb/\xff\xfe-a.png";
  r.failure_reason = "bad \xc3";  // A truncated two-byte sequence.
  std::string text;
  ASSERT_NO_THROW(text = FormatEntryReport(r));
  EntryReport back;
  ASSERT_EQ(FromJson(json::parse(text), &back), "");
  EXPECT_EQ(back.keyframe_a.source, "rgb/\xef\xbf\xbd\xef\xbf\xbd-a.png");  // U+FFFD twice.
  EXPECT_EQ(back.failure_reason, "bad \xef\xbf\xbd");
  EXPECT_EQ(back.keyframe_b.source, "b.png");
}

TEST(EntryReport, BriefReportHasOneKeyValueLineEach) {
  const std::string brief = BriefReport(Filled());
  EXPECT_NE(brief.find("success true\n"), std::string::npos) << brief;
  EXPECT_NE(brief.find("points 280\n"), std::string::npos) << brief;
  EXPECT_NE(brief.find("mesh_vertices 250\n"), std::string::npos) << brief;
  EXPECT_NE(brief.find("gate_track_inliers 140\n"), std::string::npos) << brief;
  EXPECT_NE(brief.find("b_tries 2\n"), std::string::npos) << brief;
  EXPECT_NE(brief.find("mesh_mode sparse\n"), std::string::npos) << brief;
  EntryReport dense = Filled();
  dense.meshing.mode = "dense";
  dense.meshing.dense_valid_fraction = 0.81;
  EXPECT_NE(BriefReport(dense).find("mesh_mode dense 0.810000\n"), std::string::npos);
  EntryReport fell_back = Filled();
  fell_back.meshing.dense_fallback_reason = "dense mesh has no triangles";
  EXPECT_NE(BriefReport(fell_back).find("mesh_mode sparse (dense mesh has no triangles)\n"),
            std::string::npos);
  EXPECT_NE(brief.find("scale none (up to scale)"), std::string::npos) << brief;
  EXPECT_EQ(brief.find("failure "), std::string::npos) << brief;
}

// A pair the odometry scaled: report.json says metres, the figures and the source, and reads
// back; a layout-1 report's note string reads as unscaled.
TEST(EntryReport, ScaleSaysTheUnitsAndTheSource) {
  PairReconstruction recon;
  recon.success = true;
  recon.geometry.translation = Eigen::Vector3d(0.3, 0, 0);
  ScaleEstimate scale;
  scale.source = ScaleSource::kOdometry;
  scale.metres_per_unit = 0.3;
  scale.odometry_metres_per_unit = 0.3;
  scale.uncertainty_rel = 0.047;
  const EntryReport r =
      MakeEntryReport(recon, {}, {}, BouguetCamera{}, PairOptions{}, false, {}, scale);
  const json j = ToJson(r);
  EXPECT_EQ(j["scale"]["units"], "metres");
  EXPECT_EQ(j["scale"]["source"], "odometry");
  EXPECT_EQ(j["scale"]["metres_per_unit"], 0.3);
  EntryReport back;
  ASSERT_EQ(FromJson(j, &back), "");
  EXPECT_EQ(back.scale.uncertainty_rel, 0.047);
  EXPECT_NE(BriefReport(back).find("scale odometry 0.300000 m/unit"), std::string::npos);
  ASSERT_EQ(FromJson(json{{"scale", "up to scale: ..."}}, &back), "");
  EXPECT_EQ(back.scale.units, "baseline");
  EXPECT_EQ(MakeEntryReport(recon, {}, {}, BouguetCamera{}, PairOptions{}, false).scale.source,
            "none");
}

TEST(EntryReport, FailedPairHasNoPreviewOrEncodeTimings) {
  EntryReport r;
  r.failure_reason = "not enough matches";
  const json j = ToJson(r);
  EXPECT_FALSE(j.contains("preview"));
  EXPECT_FALSE(j["timings_s"].contains("encode"));
  EntryReport back;
  ASSERT_EQ(FromJson(j, &back), "");
  EXPECT_FALSE(back.success);
  EXPECT_EQ(back.failure_reason, "not enough matches");
  EXPECT_FALSE(back.preview.has_value());
}

TEST(EntryReport, ReadsAPartialReportAndRejectsBadOnes) {
  EntryReport r;
  ASSERT_EQ(FromJson(json{{"success", true}, {"counts", {{"mesh_vertices", 5}}}}, &r), "");
  EXPECT_TRUE(r.success);
  EXPECT_EQ(r.counts.mesh_vertices, 5u);
  EXPECT_EQ(r.schema_version, 1);  // Before the field existed.
  EXPECT_NE(FromJson(json{{"success", "yes"}}, &r), "");
  EXPECT_NE(FromJson(json{{"schema_version", kEntryReportSchemaVersion + 1}}, &r).find("newer"),
            std::string::npos);
  EXPECT_NE(FromJson(json::array(), &r), "");
}

// An integer field takes an integer its type holds, or a float with an integral value; what
// would wrap or overflow on the cast is refused with the field's name.
TEST(EntryReport, RefusesIntegersTheFieldCannotHold) {
  EntryReport r;
  ASSERT_EQ(FromJson(json{{"counts", {{"features_a", 1200.0}}}}, &r), "");
  EXPECT_EQ(r.counts.features_a, 1200);
  for (const json& bad : {json(6.93015e19), json(4294967297LL), json(1.5), json("7")}) {
    const std::string error = FromJson(json{{"counts", {{"features_a", bad}}}}, &r);
    EXPECT_NE(error.find("features_a"), std::string::npos) << bad.dump() << ": " << error;
  }
  const std::string error =
      FromJson(json{{"camera", {{"image_size", json::array({640, 1e30})}}}}, &r);
  EXPECT_NE(error.find("image_size"), std::string::npos) << error;
  for (const json& bad : {json(18446744073709551615ULL), json(-1)}) {
    const std::string sequence_error =
        FromJson(json{{"keyframes", {{"a", {{"sequence", bad}}}}}}, &r);
    EXPECT_NE(sequence_error.find("sequence"), std::string::npos) << sequence_error;
  }
}

// Every key report.json has, by its path (keyframes.b as keyframes.a, array elements as []),
// into `out`.
void KeyPaths(const json& j, const std::string& prefix, std::vector<std::string>* out) {
  for (const auto& [key, value] : j.items()) {
    const std::string path = prefix.empty() ? key : prefix + "." + key;
    if (value.is_object()) {
      KeyPaths(value, path == "keyframes.b" ? "keyframes.a" : path, out);
    } else if (value.is_array() && !value.empty() && value.front().is_object()) {
      KeyPaths(value.front(), path + "[]", out);
    } else {
      out->push_back(path);
    }
  }
}

// docs/report_schema.md documents every field, by its path, and the current schema version.
TEST(EntryReport, EveryFieldIsDocumented) {
  std::ifstream in(std::filesystem::path(MM_SOURCE_DIR) / "docs/report_schema.md");
  std::ostringstream doc;
  doc << in.rdbuf();
  ASSERT_FALSE(doc.str().empty());
  std::vector<std::string> paths;
  KeyPaths(ToJson(Filled()), "", &paths);
  EXPECT_GT(paths.size(), 60u);
  for (const std::string& path : paths) {
    EXPECT_NE(doc.str().find("| `" + path + "` |"), std::string::npos)
        << path << " is not documented in docs/report_schema.md";
  }
  EXPECT_NE(
      doc.str().find("# report.json (schema " + std::to_string(kEntryReportSchemaVersion) + ")"),
      std::string::npos);
}

}  // namespace
}  // namespace mm
