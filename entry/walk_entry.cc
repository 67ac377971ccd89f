#include "entry/walk_entry.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cstdio>
#include <map>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <sstream>

#include "base/stats.h"
#include "base/text_file.h"
#include "base/version.h"
#include "base/wall_clock.h"
#include "calib/calib_io.h"
#include "entry/mesh_gltf.h"
#include "entry/mesh_io.h"
#include "entry/preview.h"
#include "render/renderer.h"

namespace mm {
namespace {

double SecondsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

// TUM trajectory format (Sturm et al. 2012): `timestamp tx ty tz qx qy qz qw`, the camera's
// pose in the world (camera-to-world).
std::string TrajectoryText(const WalkMap& map, std::span<const KeyframeInfo> infos, int segment,
                           double metres_per_unit, const std::string& units) {
  std::ostringstream out;
  out.precision(9);
  out << "# monomesh walk: keyframe poses of segment " << segment
      << ", camera-to-world (world = the segment's first keyframe, OpenCV axes), " << units
      << "\n# timestamp tx ty tz qx qy qz qw\n";
  for (size_t i = 0; i < map.keyframes().size(); ++i) {
    const WalkKeyframe& k = map.keyframes()[i];
    if (!k.registered || k.segment != segment) continue;
    const Eigen::Isometry3d world_from_cam = k.cam_from_segment.inverse();
    const Eigen::Quaterniond q(world_from_cam.linear());
    const Eigen::Vector3d t = metres_per_unit * world_from_cam.translation();
    const double time = i < infos.size() ? infos[i].source_time_s : k.timestamp_s;
    char line[256];
    std::snprintf(line, sizeof(line), "%.6f %.9g %.9g %.9g %.9g %.9g %.9g %.9g\n", time, t.x(),
                  t.y(), t.z(), q.x(), q.y(), q.z(), q.w());
    out << line;
  }
  return out.str();
}

}  // namespace

std::string EncodeKeyframeJpeg(const cv::Mat& image) {
  cv::Mat colour = image;
  if (image.channels() == 1) cv::cvtColor(image, colour, cv::COLOR_GRAY2BGR);
  std::vector<uchar> jpeg;
  cv::imencode(".jpg", colour, jpeg, {cv::IMWRITE_JPEG_QUALITY, 90});
  return {jpeg.begin(), jpeg.end()};
}

cv::Mat DecodeKeyframeJpeg(const std::string& jpeg) {
  if (jpeg.empty()) return {};
  const cv::Mat raw(1, static_cast<int>(jpeg.size()), CV_8UC1, const_cast<char*>(jpeg.data()));
  return cv::imdecode(raw, cv::IMREAD_COLOR);
}

std::string WalkKeyframeImageName(int index) {
  char name[32];
  std::snprintf(name, sizeof(name), "keyframe_%04d.jpg", index);
  return name;
}

EncodedEntry EncodeWalkEntry(const WalkEntryInput& in,
                             std::chrono::steady_clock::time_point started, WalkReport* report) {
  const WalkMap& map = *in.map;
  const std::vector<WalkKeyframe>& keyframes = map.keyframes();
  const std::vector<WalkPoint>& points = map.points();
  const int segment = in.mesh != nullptr ? in.mesh->summary.segment : LargestSegment(map);
  EncodedEntry out;
  WalkReport& r = *report;
  r.monomesh_version = kMonomeshVersion;
  r.boot_id = BootId();
  r.stop_reason = in.stop_reason;
  r.frames = in.frames;
  r.map_segment = segment;
  r.camera = {.width = in.camera.width,
              .height = in.camera.height,
              .fc = in.camera.fc,
              .cc = in.camera.cc,
              .alpha_c = in.camera.alpha_c,
              .kc = in.camera.kc};
  // Every length in metres when the scale is known, else in the segment's first baseline.
  r.scale = ReportScale(in.scale);
  const double metres_per_unit = r.scale.metres_per_unit;
  if (!in.scale.scaled() && r.scale.why_not.empty()) {
    r.scale.why_not =
        "a walk's map is up to scale: the baseline of its segment's first two keyframes is the "
        "unit";
  }
  const std::string units = in.scale.scaled()
                                ? "metres (scale from " + r.scale.source + ", " +
                                      std::to_string(metres_per_unit) + " m per unit)"
                                : "up to scale (the first baseline of the segment is the unit)";

  // Keyframes and segments.
  std::map<int, WalkReport::Segment> segments;
  std::vector<double> registration;
  for (size_t i = 0; i < keyframes.size(); ++i) {
    const WalkKeyframe& k = keyframes[i];
    WalkReport::Keyframe rk;
    rk.index = static_cast<int>(i);
    if (i < in.keyframe_infos.size()) rk.info = in.keyframe_infos[i];
    rk.image = WalkKeyframeImageName(static_cast<int>(i));
    rk.segment = k.segment;
    rk.registered = k.registered;
    if (i < in.summaries.size()) {
      const WalkKeyframeSummary& summary = in.summaries[i];
      rk.failure = summary.failure;
      rk.relocalized_to = summary.relocalized_to;
      rk.merged_segment = summary.merged_segment;
      rk.loop_to = summary.loop_to;
      if (rk.relocalized_to >= 0) ++r.counts.relocalizations;
      if (rk.merged_segment >= 0) ++r.counts.merges;
      if (rk.loop_to >= 0) ++r.counts.loop_closures;
      if (!k.registered) ++r.counts.lost_keyframes;
      rk.matches = summary.matches;
      rk.pnp_inliers = summary.pnp_inliers;
      rk.new_points = summary.new_points;
      rk.bundle_rms_px = summary.bundle_rms_px;
      rk.seconds = summary.time_s;
      registration.push_back(summary.time_s);
    }
    const Eigen::Quaterniond q(k.cam_from_segment.linear());
    rk.quaternion_wxyz = {q.w(), q.x(), q.y(), q.z()};
    rk.translation = metres_per_unit * k.cam_from_segment.translation();
    r.keyframes.push_back(rk);
    WalkReport::Segment& s = segments[k.segment];
    if (s.keyframes == 0) s.first_keyframe = static_cast<int>(i);
    s.segment = k.segment;
    ++s.keyframes;
    if (k.registered) ++s.registered;
    if (i < in.keyframe_jpegs.size() && !in.keyframe_jpegs[i].empty()) {
      out.files.push_back({rk.image, in.keyframe_jpegs[i]});
    }
  }
  for (const auto& [id, s] : segments) r.segments.push_back(s);
  if (!registration.empty()) {
    for (double t : registration) r.timings_s.registration_total += t;
    r.timings_s.registration_median = MedianOf(registration);
  }
  r.counts.keyframes = static_cast<int>(keyframes.size());
  r.counts.segments = static_cast<int>(std::count_if(
      segments.begin(), segments.end(), [](const auto& s) { return s.second.registered > 0; }));
  const auto seg_it = segments.find(segment);
  r.counts.registered = seg_it == segments.end() ? 0 : seg_it->second.registered;
  r.success = r.counts.registered >= 2;
  if (!r.success) {
    r.failure_reason =
        keyframes.empty() ? "the walk took no keyframe" : "no segment of two registered keyframes";
  }

  // The segment's registered keyframes, their poses and the map points.
  std::vector<int> members;
  std::map<int, int> image_of_keyframe;  // COLMAP image index.
  std::vector<Eigen::Isometry3d> cam_from_world;
  for (size_t i = 0; i < keyframes.size(); ++i) {
    if (keyframes[i].registered && keyframes[i].segment == segment) {
      image_of_keyframe[static_cast<int>(i)] = static_cast<int>(members.size());
      members.push_back(static_cast<int>(i));
      Eigen::Isometry3d cam_from_segment = keyframes[i].cam_from_segment;
      cam_from_segment.translation() *= metres_per_unit;
      cam_from_world.push_back(cam_from_segment);
    }
  }
  // Colour of each point from its first observation's keyframe (each image decoded once).
  std::vector<int> point_ids;
  for (size_t p = 0; p < points.size(); ++p) {
    if (points[p].valid && points[p].segment == segment && !points[p].observations.empty()) {
      point_ids.push_back(static_cast<int>(p));
    }
  }
  std::vector<Eigen::Matrix<uint8_t, 3, 1>> colors(point_ids.size(),
                                                   Eigen::Matrix<uint8_t, 3, 1>(128, 128, 128));
  {
    std::map<int, std::vector<size_t>> by_keyframe;
    for (size_t n = 0; n < point_ids.size(); ++n) {
      by_keyframe[points[static_cast<size_t>(point_ids[n])].observations.front().keyframe]
          .push_back(n);
    }
    for (const auto& [k, list] : by_keyframe) {
      if (static_cast<size_t>(k) >= in.keyframe_jpegs.size()) continue;
      const cv::Mat image = DecodeKeyframeJpeg(in.keyframe_jpegs[static_cast<size_t>(k)]);
      if (image.empty()) continue;
      std::vector<Eigen::Vector2d> pixels;
      for (size_t n : list) {
        const WalkPoint::Observation& o =
            points[static_cast<size_t>(point_ids[n])].observations.front();
        const Eigen::Vector2f& pt =
            keyframes[static_cast<size_t>(k)].keypoint_pixels[static_cast<size_t>(o.keypoint)];
        pixels.push_back(pt.cast<double>());
      }
      const auto sampled = SampleColors(image, pixels);
      for (size_t j = 0; j < list.size(); ++j) colors[list[j]] = sampled[j];
    }
  }
  std::vector<Eigen::Vector3d> positions;
  for (int id : point_ids)
    positions.push_back(metres_per_unit * points[static_cast<size_t>(id)].position_in_segment);
  r.counts.points = static_cast<int>(positions.size());

  // The mesh.
  if (in.mesh != nullptr) {
    const WalkMeshSummary& m = in.mesh->summary;
    r.counts.mesh_parts = m.parts;
    r.counts.mesh_dense_parts = m.dense_parts;
    r.counts.mesh_vertices = m.vertices;
    r.counts.mesh_triangles = m.triangles;
    r.counts.mesh_dropped_overlap = m.dropped_overlap;
    r.timings_s.mesh = m.seconds;
  }
  Mesh merged;
  if (in.mesh != nullptr && !in.mesh->parts.empty()) {
    std::vector<Mesh> part_meshes;
    part_meshes.reserve(in.mesh->parts.size());
    for (const WalkMeshPart& part : in.mesh->parts) {
      part_meshes.push_back(part.mesh);
      for (Eigen::Vector3f& v : part_meshes.back().vertices)
        v *= static_cast<float>(metres_per_unit);
    }
    std::vector<GlbPart> parts;
    for (size_t i = 0; i < in.mesh->parts.size(); ++i) {
      const WalkMeshPart& part = in.mesh->parts[i];
      const auto k = static_cast<size_t>(part.keyframe);
      parts.push_back(
          {.mesh = &part_meshes[i],
           .texture_jpeg = k < in.keyframe_jpegs.size() ? &in.keyframe_jpegs[k] : nullptr,
           .name = "keyframe_" + std::to_string(part.keyframe)});
    }
    GlbInfo info;
    info.scale_note = units;
    info.frame_note = "the first keyframe of segment " + std::to_string(segment) +
                      "; stored as glTF axes (x, -y, -z) of OpenCV's camera frame";
    info.node_name = "walk_map";
    out.files.push_back({"map.glb", EncodeGlb(parts, info)});
    merged = in.mesh->Merged();
    for (Eigen::Vector3f& v : merged.vertices) v *= static_cast<float>(metres_per_unit);
    out.files.push_back({"map.ply", EncodePly(merged, "monomesh walk map, " + units)});
  }
  out.files.push_back(
      {"trajectory.txt", TrajectoryText(map, in.keyframe_infos, segment, metres_per_unit, units)});
  out.files.push_back(
      {"points.ply", EncodePointsPly(positions, colors, "monomesh walk map points, " + units)});

  // The COLMAP model of the segment (the entry folder is the model folder).
  ColmapModel colmap;
  colmap.width = in.camera.width;
  colmap.height = in.camera.height;
  colmap.K = in.camera.K();
  colmap.scale_note = units;
  for (size_t m = 0; m < members.size(); ++m) {
    colmap.images.push_back({WalkKeyframeImageName(members[m]), cam_from_world[m]});
  }
  for (size_t n = 0; n < point_ids.size(); ++n) {
    const WalkPoint& point = points[static_cast<size_t>(point_ids[n])];
    ColmapModel::Point cp;
    cp.position = metres_per_unit * point.position_in_segment;
    cp.rgb = colors[n];
    for (const WalkPoint::Observation& o : point.observations) {
      const auto it = image_of_keyframe.find(o.keyframe);
      if (it == image_of_keyframe.end()) continue;
      const Eigen::Vector2f& pt = keyframes[static_cast<size_t>(o.keyframe)]
                                      .keypoint_pixels[static_cast<size_t>(o.keypoint)];
      cp.track.push_back({it->second, pt.cast<double>()});
    }
    colmap.points.push_back(std::move(cp));
  }
  const ColmapText colmap_text = EncodeColmapModel(colmap);
  out.files.push_back({"cameras.txt", colmap_text.cameras});
  out.files.push_back({"images.txt", colmap_text.images});
  out.files.push_back({"points3D.txt", colmap_text.points3d});
  out.files.push_back({"calibration.toml", FormatCalibrationToml(in.camera)});

  // preview.png: plan and oblique views (EGL, headless); an entry without it says why.
  {
    const auto render_start = std::chrono::steady_clock::now();
    Renderer renderer;
    std::string preview_error = renderer.error();
    cv::Mat preview;
    if (renderer.ok() && !cam_from_world.empty()) {
      preview = RenderWalkPreview(renderer, merged, cam_from_world, in.camera.K(), in.camera.width,
                                  in.camera.height, &preview_error);
    } else if (cam_from_world.empty()) {
      preview_error = "no registered keyframe to show";
    }
    std::vector<uchar> png;
    if (!preview.empty() && cv::imencode(".png", preview, png)) {
      out.files.push_back({"preview.png", std::string(png.begin(), png.end())});
      r.preview = EntryReport::Preview{
          .file = "preview.png", .renderer = renderer.gl_renderer(), .error = {}};
    } else {
      EntryReport::Preview none;
      none.error = preview_error.empty() ? "PNG encoding failed" : preview_error;
      r.preview = none;
    }
    r.timings_s.preview = SecondsSince(render_start);
  }
  r.timings_s.walk = in.walk_seconds;
  const TrackRefineSummary& f = in.refinement;
  r.refinement = {.ran = f.ran,
                  .skipped = f.skipped,
                  .pairs = f.pairs,
                  .verified_pairs = f.verified_pairs,
                  .points = f.points,
                  .observations = f.observations,
                  .rms_px = f.bundle.final_rms_px};
  r.timings_s.refinement = in.refinement_seconds;
  r.timings_s.encode = SecondsSince(started) - r.timings_s.preview - r.timings_s.mesh -
                       r.timings_s.refinement;
  out.files.push_back({"report.json", FormatWalkReport(r)});
  return out;
}

std::string ReadEntryKind(const std::filesystem::path& entry_dir, std::string* error) {
  nlohmann::json j;
  *error = ReadReportJson(entry_dir, &j);
  return error->empty() ? ReportKind(j) : std::string();
}

std::string ReadWalkReport(const std::filesystem::path& entry_dir, WalkReport* report) {
  nlohmann::json j;
  if (std::string error = ReadReportJson(entry_dir, &j); !error.empty()) return error;
  if (std::string problem = FromJson(j, report); !problem.empty()) {
    return (entry_dir / "report.json").string() + ": " + problem;
  }
  return {};
}

}  // namespace mm
