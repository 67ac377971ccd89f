#include "eval/walk_eval.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <nlohmann/json.hpp>
#include <opencv2/core/utility.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <optional>

#include "base/clock.h"
#include "base/stats.h"
#include "calib/undistort.h"
#include "dataset/tum.h"
#include "entry/json_text.h"
#include "eval/mesh_checks.h"
#include "eval/tum_pairs.h"
#include "map/walk_tracker.h"
#include "render/renderer.h"

namespace mm {
namespace {

// Scale of the Sim(3) that aligns the estimated centres of `ids` to their ground truth; 0 with
// fewer than 3.
double ScaleOf(const std::vector<int>& ids, const std::vector<Eigen::Vector3d>& estimated,
               const std::vector<Eigen::Vector3d>& truth) {
  if (ids.size() < 3) return 0.0;
  Eigen::Matrix3Xd src(3, static_cast<Eigen::Index>(ids.size()));
  Eigen::Matrix3Xd dst(3, static_cast<Eigen::Index>(ids.size()));
  for (size_t i = 0; i < ids.size(); ++i) {
    src.col(static_cast<Eigen::Index>(i)) = estimated[static_cast<size_t>(ids[i])];
    dst.col(static_cast<Eigen::Index>(i)) = truth[static_cast<size_t>(ids[i])];
  }
  return AlignSim3(src, dst).topLeftCorner<3, 3>().col(0).norm();
}

}  // namespace

std::string WalkEvalOptions::Check() const {
  if (std::string p = walk.Check(); !p.empty()) return "walk." + p;
  if (!every_frame) {
    if (std::string p = gate.Check(); !p.empty()) return "gate." + p;
  }
  if (!(max_gt_dt_s >= 0)) return "max_gt_dt_s: must be >= 0";
  if (map_depth_views < 0) return "map_depth_views: must be >= 0";
  if (std::string p = mesh.Check(); !p.empty()) return "mesh." + p;
  if (std::string p = refinement.Check(); !p.empty()) return "refinement." + p;
  return {};
}

Eigen::Matrix4d AlignSim3(const Eigen::Matrix3Xd& source, const Eigen::Matrix3Xd& target) {
  return Eigen::umeyama(source, target, true);
}

WalkEvalResult EvaluateWalk(const std::filesystem::path& dataset, const BouguetCamera& camera,
                            const WalkEvalOptions& options) {
  WalkEvalResult result;
  if (std::string problem = options.Check(); !problem.empty()) {
    result.failure_reason = "options: " + problem;
    return result;
  }
  if (std::string missing = MissingGroundTruth(dataset); !missing.empty()) {
    result.failure_reason = missing;
    return result;
  }
  TumSequence sequence;
  try {
    sequence = ReadTumSequence(dataset, options.list);
  } catch (const DatasetError& e) {
    result.failure_reason = e.what();
    return result;
  }
  const std::vector<TumFrame>& frames = sequence.frames;
  const std::vector<TumFrame>& depth_frames = sequence.depth_frames;
  const Trajectory& trajectory = sequence.trajectory;
  if (frames.empty()) {
    result.failure_reason = "no frames in the list";
    return result;
  }
  if (options.threads > 0) cv::setNumThreads(options.threads);

  BouguetCamera sized = camera;
  std::optional<Undistorter> undistorter;
  std::optional<WalkMap> every_frame_map;  // every_frame: each frame straight into the map.
  std::optional<WalkTracker> tracker;      // Else: the walk's keyframe policy.
  WalkMap* map = nullptr;
  Eigen::Matrix3d k_matrix = Eigen::Matrix3d::Identity();  // Of the undistorted frames.
  const double cpu_start = ThreadCpuSeconds();
  std::vector<double> frame_cpu;  // Frames that did not become keyframes.

  auto keyframe_eval = [&](size_t frame, const WalkKeyframeSummary& summary, double cpu_s) {
    WalkKeyframeEval k;
    k.frame = static_cast<int>(frame);
    k.timestamp_s = frames[frame].timestamp_s;
    k.image = frames[frame].path.string();
    k.walk = summary;
    k.cpu_s = cpu_s;
    result.keyframes.push_back(std::move(k));
  };

  for (size_t i = 0; i < frames.size(); ++i) {
    cv::Mat image = cv::imread(frames[i].path.string(), cv::IMREAD_GRAYSCALE);
    if (image.empty()) {
      result.failure_reason = "cannot read image " + frames[i].path.string() + " (line " +
                              std::to_string(frames[i].line) + ")";
      return result;
    }
    if (sized.width == 0) {
      sized.width = image.cols;
      sized.height = image.rows;
    }
    if (image.cols != sized.width || image.rows != sized.height) {
      result.failure_reason = "image " + frames[i].path.string() + " is " +
                              std::to_string(image.cols) + "x" + std::to_string(image.rows) +
                              ", the calibration " + std::to_string(sized.width) + "x" +
                              std::to_string(sized.height);
      return result;
    }
    if (sized.HasDistortion()) {
      if (!undistorter) undistorter.emplace(sized);
      image = undistorter->Apply(image);
    }
    const Eigen::Matrix3d k = undistorter ? undistorter->output_camera().K() : sized.K();
    k_matrix = k;
    ++result.summary.frames;
    if (options.every_frame) {
      if (!every_frame_map) map = &every_frame_map.emplace(k, options.walk);
      const double cpu0 = ThreadCpuSeconds();
      const WalkKeyframeSummary summary =
          every_frame_map->AddKeyframe(image, frames[i].timestamp_s);
      keyframe_eval(i, summary, ThreadCpuSeconds() - cpu0);
      continue;
    }
    if (!tracker) {
      tracker.emplace(k, WalkTrackerOptions{.walk = options.walk, .gate = options.gate});
      map = &tracker->mutable_map();
    }
    const double cpu0 = ThreadCpuSeconds();
    const WalkFrameStep step = tracker->AddFrame(image, frames[i].timestamp_s);
    const double cpu_s = ThreadCpuSeconds() - cpu0;
    if (step.added) {
      keyframe_eval(i, *step.added, cpu_s);
      result.keyframes.back().reason = step.keyframe_reason;
    } else {
      frame_cpu.push_back(cpu_s);
      if (step.tracked) ++result.summary.tracked_frames;
    }
  }
  if (tracker) tracker->Finish();
  if (every_frame_map) every_frame_map->Finish();
  WalkEvalSummary& s = result.summary;
  s.cpu_total_s = ThreadCpuSeconds() - cpu_start;
  s.keyframes = static_cast<int>(result.keyframes.size());
  s.segments = map ? map->segments() : 0;
  s.cpu_per_frame_s_median = frame_cpu.empty() ? 0.0 : MedianOf(frame_cpu);
  // A keyframe's image as the walk saw it (cv::imread flags: gray or colour), undistorted.
  const auto keyframe_image = [&](int index, int imread_flags) {
    const auto frame = static_cast<size_t>(result.keyframes[static_cast<size_t>(index)].frame);
    cv::Mat image = cv::imread(frames[frame].path.string(), imread_flags);
    if (undistorter && !image.empty()) image = undistorter->Apply(image);
    return image;
  };
  if (map && options.refine) {
    // The walk's map, refined as the daemon refines it once a walk ends.
    s.refinement = RefineSegment(
        map, LargestSegment(*map), k_matrix,
        [&](int index) { return keyframe_image(index, cv::IMREAD_GRAYSCALE); }, options.refinement);
  }
  if (map) {
    s.relocalizations = map->relocalizations();
    s.merges = map->merges();
    s.loop_closures = map->loop_closures();
    s.global_bundles = map->global_bundles();
    s.global_bundle_cpu_s = map->global_bundle_cpu_s();
    s.lost_keyframes = map->lost_keyframes();
    s.points = static_cast<int>(std::count_if(map->points().begin(), map->points().end(),
                                              [](const WalkPoint& p) { return p.valid; }));
  }
  std::map<int, int> size_of_segment;
  std::vector<double> cpu;
  std::vector<Eigen::Vector3d> estimated(result.keyframes.size()), truth(result.keyframes.size());
  std::vector<Eigen::Isometry3d> world_from_cam_gt(result.keyframes.size());
  for (size_t i = 0; i < result.keyframes.size(); ++i) {
    WalkKeyframeEval& k = result.keyframes[i];
    cpu.push_back(k.cpu_s);
    // The final map: keyframes relocalised later or in a segment merged since count.
    const WalkKeyframe& final_keyframe = map->keyframes()[i];
    k.segment = final_keyframe.segment;
    if (!final_keyframe.registered) continue;
    if (final_keyframe.joined) ++s.registered;
    const std::optional<Eigen::Isometry3d> gt =
        trajectory.WorldFromCamAt(k.timestamp_s, options.max_gt_dt_s);
    if (!gt) continue;
    k.has_gt = true;
    world_from_cam_gt[i] = *gt;
    truth[i] = gt->translation();
    estimated[i] = map->keyframes()[i].cam_from_segment.inverse().translation();
    k.centre_in_segment = estimated[i];
    k.centre_gt = truth[i];
    ++size_of_segment[k.segment];
  }
  s.cpu_per_keyframe_s_median = cpu.empty() ? 0.0 : MedianOf(cpu);
  if (size_of_segment.empty()) return result.ok = true, result;
  s.evaluated_segment =
      std::max_element(size_of_segment.begin(), size_of_segment.end(),
                       [](const auto& a, const auto& b) { return a.second < b.second; })
          ->first;
  std::vector<int> ids;
  for (size_t i = 0; i < result.keyframes.size(); ++i) {
    WalkKeyframeEval& k = result.keyframes[i];
    if (k.has_gt && map->keyframes()[i].registered && k.segment == s.evaluated_segment) {
      k.in_evaluated_segment = true;
      ids.push_back(static_cast<int>(i));
    }
  }
  s.evaluated_keyframes = static_cast<int>(ids.size());
  for (size_t j = 1; j < ids.size(); ++j) {
    s.path_length_m +=
        (truth[static_cast<size_t>(ids[j])] - truth[static_cast<size_t>(ids[j - 1])]).norm();
  }
  std::vector<double> rpe;
  for (size_t j = 1; j < ids.size(); ++j) {
    const auto a = static_cast<size_t>(ids[j - 1]);
    const auto b = static_cast<size_t>(ids[j]);
    const Eigen::Isometry3d est =
        map->keyframes()[b].cam_from_segment * map->keyframes()[a].cam_from_segment.inverse();
    const Eigen::Isometry3d gt = CamBFromCamA(world_from_cam_gt[a], world_from_cam_gt[b]);
    result.keyframes[b].rpe_rot_deg = RotationErrorDeg(est.linear(), gt.linear());
    rpe.push_back(result.keyframes[b].rpe_rot_deg);
  }
  s.rpe_rot_deg_median = rpe.empty() ? 0.0 : MedianOf(rpe);
  if (ids.size() >= 3) {
    Eigen::Matrix3Xd src(3, static_cast<Eigen::Index>(ids.size()));
    Eigen::Matrix3Xd dst(3, static_cast<Eigen::Index>(ids.size()));
    for (size_t j = 0; j < ids.size(); ++j) {
      src.col(static_cast<Eigen::Index>(j)) = estimated[static_cast<size_t>(ids[j])];
      dst.col(static_cast<Eigen::Index>(j)) = truth[static_cast<size_t>(ids[j])];
    }
    const Eigen::Matrix4d sim3 = AlignSim3(src, dst);
    s.sim3_scale = sim3.topLeftCorner<3, 3>().col(0).norm();
    double sum = 0.0;
    for (size_t j = 0; j < ids.size(); ++j) {
      const Eigen::Vector3d aligned =
          (sim3 * src.col(static_cast<Eigen::Index>(j)).homogeneous()).head<3>();
      const double err = (aligned - dst.col(static_cast<Eigen::Index>(j))).norm();
      result.keyframes[static_cast<size_t>(ids[j])].position_err_m = err;
      sum += err * err;
      s.ate_max_m = std::max(s.ate_max_m, err);
    }
    s.ate_rmse_m = std::sqrt(sum / static_cast<double>(ids.size()));
    // The depth map of a keyframe (16-bit, the calibration's size), through the undistorted
    // camera as the keyframes went (nearest, unblended); empty when there is none.
    const auto depth_at = [&](double timestamp_s) {
      const int d = NearestFrame(depth_frames, timestamp_s, options.max_depth_dt_s);
      if (d < 0) return cv::Mat();
      cv::Mat depth =
          cv::imread(depth_frames[static_cast<size_t>(d)].path.string(), cv::IMREAD_UNCHANGED);
      if (depth.type() != CV_16UC1 || depth.cols != sized.width || depth.rows != sized.height) {
        return cv::Mat();
      }
      return undistorter ? undistorter->ApplyNearest(depth) : depth;
    };
    std::vector<double> depth_errors;
    for (int id : ids) {
      WalkKeyframeEval& k = result.keyframes[static_cast<size_t>(id)];
      const cv::Mat depth = depth_at(k.timestamp_s);
      if (depth.empty()) continue;
      const WalkKeyframe& keyframe = map->keyframes()[static_cast<size_t>(id)];
      std::vector<double> errors, ratios;
      for (size_t i = 0; i < keyframe.point_of_keypoint.size(); ++i) {
        const int point = keyframe.point_of_keypoint[i];
        if (point < 0 || !map->points()[static_cast<size_t>(point)].valid) continue;
        const Eigen::Vector2f& pixel = keyframe.keypoint_pixels[i];
        const int u = static_cast<int>(std::lround(pixel.x()));
        const int v = static_cast<int>(std::lround(pixel.y()));
        if (u < 0 || v < 0 || u >= depth.cols || v >= depth.rows) continue;
        const double truth_m = depth.at<uint16_t>(v, u) / 5000.0;
        if (truth_m <= 0) continue;
        const double z = (keyframe.cam_from_segment *
                          map->points()[static_cast<size_t>(point)].position_in_segment)
                             .z();
        errors.push_back(std::abs(s.sim3_scale * z - truth_m) / truth_m);
        ratios.push_back(truth_m / z);
      }
      if (errors.empty()) continue;
      k.depth_points = static_cast<int>(errors.size());
      k.point_depth_rel_err_median = MedianOf(errors);
      k.depth_scale = MedianOf(ratios);
      ++s.depth_keyframes;
      depth_errors.insert(depth_errors.end(), errors.begin(), errors.end());
    }
    if (!depth_errors.empty()) {
      s.depth_points = static_cast<int>(depth_errors.size());
      s.point_depth_rel_err_median = MedianOf(depth_errors);
      s.point_depth_rel_err_p90 = QuantileOf(depth_errors, 0.9);
    }
    if (options.map_depth_views > 0) {
      // The map mesh, from the keyframes' own images, into the ground truth's frame.
      const double mesh_start = ThreadCpuSeconds();
      const WalkMesh mesh = BuildWalkMesh(
          *map, s.evaluated_segment, k_matrix,
          [&](int index) { return keyframe_image(index, cv::IMREAD_COLOR); }, options.mesh);
      s.map_mesh_parts = mesh.summary.parts;
      s.map_mesh_triangles = mesh.summary.triangles;
      s.map_mesh_dropped_overlap = mesh.summary.dropped_overlap;
      s.map_mesh_dropped_free_space = mesh.summary.dropped_free_space;
      s.map_mesh_cpu_s = ThreadCpuSeconds() - mesh_start;
      Mesh world = mesh.Merged();
      const Eigen::Matrix3f sr = sim3.topLeftCorner<3, 3>().cast<float>();
      const Eigen::Vector3f st = sim3.topRightCorner<3, 1>().cast<float>();
      for (Eigen::Vector3f& v : world.vertices) v = sr * v + st;
      std::vector<double> medians;
      double coverage = 0.0;
      Renderer renderer;
      const int views = std::min<int>(options.map_depth_views, static_cast<int>(ids.size()));
      for (int v = 0; v < views && renderer.ok() && !world.triangles.empty(); ++v) {
        const size_t j =
            views == 1 ? 0
                       : static_cast<size_t>(v) * (ids.size() - 1) / static_cast<size_t>(views - 1);
        const WalkKeyframeEval& k = result.keyframes[static_cast<size_t>(ids[j])];
        const cv::Mat depth = depth_at(k.timestamp_s);
        if (depth.empty()) continue;
        cv::Mat depth_m;
        depth.convertTo(depth_m, CV_32F, 1.0 / 5000.0);
        RenderCamera view;
        view.K = k_matrix;
        view.width = depth.cols;
        view.height = depth.rows;
        view.cam_from_world = world_from_cam_gt[static_cast<size_t>(ids[j])].inverse();
        const MeshDepthEval e = EvaluateMeshDepth(renderer, world, view, depth_m, 1.0);
        if (!e.success || e.covered_pixels == 0) continue;
        medians.push_back(e.median_rel_err);
        s.map_depth_rel_err_per_view.push_back(e.median_rel_err);
        s.map_depth_ratio_per_view.push_back(e.median_ratio);
        s.map_coverage_per_view.push_back(e.coverage);
        s.map_depth_rel_err_p90_max = std::max(s.map_depth_rel_err_p90_max, e.p90_rel_err);
        coverage += e.coverage;
      }
      if (!medians.empty()) {
        s.map_depth_views = static_cast<int>(medians.size());
        s.map_depth_rel_err_median = MedianOf(medians);
        s.map_depth_rel_err_max_median = *std::max_element(medians.begin(), medians.end());
        s.map_coverage_mean = coverage / static_cast<double>(medians.size());
      }
    }
    const size_t third = ids.size() / 3;
    const std::vector<int> first(ids.begin(), ids.begin() + static_cast<std::ptrdiff_t>(third));
    const std::vector<int> last(ids.end() - static_cast<std::ptrdiff_t>(third), ids.end());
    const double s_first = ScaleOf(first, estimated, truth);
    const double s_last = ScaleOf(last, estimated, truth);
    if (s_first > 0 && s_last > 0) s.scale_drift = std::abs(s_last / s_first - 1.0);
    // The same thirds, read from the depth maps instead of the trajectory: the median local
    // scale (depth-map depth / map depth) of each third's keyframes.
    auto depth_scale_of = [&](const std::vector<int>& third_ids) {
      std::vector<double> scales;
      for (int id : third_ids) {
        const WalkKeyframeEval& k = result.keyframes[static_cast<size_t>(id)];
        if (k.depth_points > 0) scales.push_back(k.depth_scale);
      }
      return scales.size() >= 3 ? MedianOf(scales) : 0.0;
    };
    const double d_first = depth_scale_of(first), d_last = depth_scale_of(last);
    if (d_first > 0 && d_last > 0) s.depth_scale_drift = std::abs(d_last / d_first - 1.0);
  }
  result.ok = true;
  return result;
}

std::string FormatWalkKeyframeLine(const WalkKeyframeEval& k) {
  char line[512];
  std::snprintf(
      line, sizeof line,
      "kf %3d frame %5d seg %d %s matches %4d 3d %4d prior %4d inliers %4d new %4d ba %.2f px "
      "err %6.2f cm rpe %5.2f deg cpu %5.1f ms (sift %.0f match %.0f pose %.0f ba %.0f) %s%s%s",
      k.walk.index, k.frame, k.segment,
      !k.walk.registered           ? "LOST "
      : k.walk.merged_segment >= 0 ? "MERGE"
      : k.walk.loop_to >= 0        ? "LOOP "
      : k.walk.relocalized_to >= 0 ? "RELOC"
      : k.walk.bridged             ? "BRIDG"
                                   : (k.walk.failure.empty() ? "reg  " : "NEW  "),
      k.walk.matches, k.walk.matches_3d, k.walk.prior_matches, k.walk.pnp_inliers,
      k.walk.new_points, k.walk.bundle_rms_px, 100.0 * k.position_err_m, k.rpe_rot_deg,
      1e3 * k.cpu_s, 1e3 * k.walk.sift_s, 1e3 * k.walk.matching_s, 1e3 * k.walk.pose_s,
      1e3 * k.walk.bundle_s, k.reason.c_str(), k.walk.failure.empty() ? "" : "  ",
      k.walk.failure.c_str());
  return std::string(line) + "\n";
}

std::string FormatWalkSummary(const WalkEvalSummary& s) {
  char text[1024];
  std::snprintf(
      text, sizeof text,
      "walk: %d frames, %d keyframes, %d registered, %d segment(s); evaluated segment "
      "%d: %d keyframes\n"
      "  ATE RMSE %.2f cm (max %.2f cm) over a %.2f m path (%.3f %%), RPE rotation "
      "median %.3f deg, scale drift %.2f %% (from the depth maps %.2f %%)\n"
      "  relocalisations %d, segments merged %d, loops closed %d (segment adjusted in the "
      "background %d times, %.2f s CPU), lost keyframes %d; %d frames tracked\n"
      "  CPU per keyframe median %.1f ms, per other frame median %.2f ms (total %.2f s), %d "
      "map points; their depth at %d keyframes: median %.2f %%, p90 %.2f %% (%d "
      "observations)\n",
      s.frames, s.keyframes, s.registered, s.segments, s.evaluated_segment, s.evaluated_keyframes,
      100.0 * s.ate_rmse_m, 100.0 * s.ate_max_m, s.path_length_m,
      s.path_length_m > 0 ? 100.0 * s.ate_rmse_m / s.path_length_m : 0.0, s.rpe_rot_deg_median,
      100.0 * s.scale_drift, 100.0 * s.depth_scale_drift, s.relocalizations, s.merges,
      s.loop_closures, s.global_bundles, s.global_bundle_cpu_s, s.lost_keyframes, s.tracked_frames,
      1e3 * s.cpu_per_keyframe_s_median, 1e3 * s.cpu_per_frame_s_median, s.cpu_total_s, s.points,
      s.depth_keyframes, 100.0 * s.point_depth_rel_err_median, 100.0 * s.point_depth_rel_err_p90,
      s.depth_points);
  std::string out = text;
  if (s.refinement.ran) {
    std::snprintf(text, sizeof text,
                  "  refined after the walk: %d of %d pairs of keyframes verified, %d tracks, "
                  "%d points with %d observations; RMS %.3f px; %.2f s CPU\n",
                  s.refinement.verified_pairs, s.refinement.pairs, s.refinement.tracks,
                  s.refinement.points, s.refinement.observations, s.refinement.bundle.final_rms_px,
                  s.refinement.cpu_s);
    out += text;
  } else if (!s.refinement.skipped.empty()) {
    out += "  not refined after the walk: " + s.refinement.skipped + "\n";
  }
  if (s.map_depth_views > 0) {
    std::snprintf(text, sizeof text,
                  "  map mesh: %d parts, %d triangles; its depth from %d ground-truth poses: "
                  "median %.2f %% (worst view %.2f %%, p90 up to %.2f %%), coverage %.0f %%\n",
                  s.map_mesh_parts, s.map_mesh_triangles, s.map_depth_views,
                  100.0 * s.map_depth_rel_err_median, 100.0 * s.map_depth_rel_err_max_median,
                  100.0 * s.map_depth_rel_err_p90_max, 100.0 * s.map_coverage_mean);
    out += text;
    out += "    per view:";
    for (size_t v = 0; v < s.map_depth_rel_err_per_view.size(); ++v) {
      std::snprintf(text, sizeof text, " %.2f %% (coverage %.0f %%)",
                    100.0 * s.map_depth_rel_err_per_view[v], 100.0 * s.map_coverage_per_view[v]);
      out += text;
    }
    std::snprintf(text, sizeof text,
                  "\n    triangles dropped: %d seen through by other keyframes, %d already held; "
                  "%.2f s CPU\n",
                  s.map_mesh_dropped_free_space, s.map_mesh_dropped_overlap, s.map_mesh_cpu_s);
    out += text;
  }
  return out;
}

std::string WalkEvalToJson(const WalkEvalResult& result) {
  using json = nlohmann::json;
  const WalkEvalSummary& s = result.summary;
  json walk = {{"frames", s.frames},
               {"keyframes", s.keyframes},
               {"registered", s.registered},
               {"segments", s.segments},
               {"evaluated_segment", s.evaluated_segment},
               {"evaluated_keyframes", s.evaluated_keyframes},
               {"ate_rmse_m", s.ate_rmse_m},
               {"ate_max_m", s.ate_max_m},
               {"path_length_m", s.path_length_m},
               {"sim3_scale", s.sim3_scale},
               {"rpe_rot_deg_median", s.rpe_rot_deg_median},
               {"scale_drift", s.scale_drift},
               {"depth_scale_drift", s.depth_scale_drift},
               {"cpu_per_keyframe_s_median", s.cpu_per_keyframe_s_median},
               {"cpu_per_frame_s_median", s.cpu_per_frame_s_median},
               {"tracked_frames", s.tracked_frames},
               {"relocalizations", s.relocalizations},
               {"merges", s.merges},
               {"loop_closures", s.loop_closures},
               {"global_bundles", s.global_bundles},
               {"global_bundle_cpu_s", s.global_bundle_cpu_s},
               {"lost_keyframes", s.lost_keyframes},
               {"cpu_total_s", s.cpu_total_s},
               {"points", s.points},
               {"refinement",
                {{"ran", s.refinement.ran},
                 {"skipped", s.refinement.skipped},
                 {"pairs", s.refinement.pairs},
                 {"verified_pairs", s.refinement.verified_pairs},
                 {"tracks", s.refinement.tracks},
                 {"points", s.refinement.points},
                 {"observations", s.refinement.observations},
                 {"rms_px", s.refinement.bundle.final_rms_px},
                 {"cpu_s", s.refinement.cpu_s}}},
               {"point_depth_rel_err",
                {{"median", s.point_depth_rel_err_median},
                 {"p90", s.point_depth_rel_err_p90},
                 {"points", s.depth_points},
                 {"keyframes", s.depth_keyframes}}},
               {"map_depth_rel_err",
                {{"median", s.map_depth_rel_err_median},
                 {"max_median", s.map_depth_rel_err_max_median},
                 {"p90_max", s.map_depth_rel_err_p90_max},
                 {"views", s.map_depth_views},
                 {"coverage_mean", s.map_coverage_mean},
                 {"per_view", s.map_depth_rel_err_per_view},
                 {"ratio_per_view", s.map_depth_ratio_per_view},
                 {"coverage_per_view", s.map_coverage_per_view}}},
               {"map_mesh",
                {{"parts", s.map_mesh_parts},
                 {"triangles", s.map_mesh_triangles},
                 {"dropped_overlap", s.map_mesh_dropped_overlap},
                 {"dropped_free_space", s.map_mesh_dropped_free_space},
                 {"cpu_s", s.map_mesh_cpu_s}}}};
  json keyframes = json::array();
  for (const WalkKeyframeEval& k : result.keyframes) {
    keyframes.push_back(
        {{"index", k.walk.index},
         {"frame", k.frame},
         {"timestamp", k.timestamp_s},
         {"image", k.image},
         {"reason", k.reason},
         {"segment", k.segment},
         {"segment_when_added", k.walk.segment},
         {"registered", k.walk.registered},
         {"relocalized_to", k.walk.relocalized_to},
         {"merged_segment", k.walk.merged_segment},
         {"loop_to", k.walk.loop_to},
         {"loop_correction", k.walk.loop_correction_m},
         {"global_bundle_applied", k.walk.global_bundle_applied},
         {"prior_matches", k.walk.prior_matches},
         {"bridged", k.walk.bridged},
         {"failure", k.walk.failure},
         {"matches", k.walk.matches},
         {"matches_3d", k.walk.matches_3d},
         {"pnp_inliers", k.walk.pnp_inliers},
         {"new_points", k.walk.new_points},
         {"bundle_rms_px", k.walk.bundle_rms_px},
         {"cpu_s", k.cpu_s},
         {"has_gt", k.has_gt},
         {"position_err_m", k.in_evaluated_segment ? json(k.position_err_m) : json()},
         {"depth_scale", k.depth_points > 0 ? json(k.depth_scale) : json()},
         {"centre_in_segment", k.walk.registered
                                   ? json::array({k.centre_in_segment.x(), k.centre_in_segment.y(),
                                                  k.centre_in_segment.z()})
                                   : json()},
         {"centre_gt",
          k.has_gt ? json::array({k.centre_gt.x(), k.centre_gt.y(), k.centre_gt.z()}) : json()},
         {"rpe_rot_deg", k.rpe_rot_deg >= 0 ? json(k.rpe_rot_deg) : json()},
         {"point_depth_rel_err_median",
          k.point_depth_rel_err_median >= 0 ? json(k.point_depth_rel_err_median) : json()}});
  }
  return JsonText(json{{"summary", {{"walk", walk}}}, {"keyframes", keyframes}}, 2) + "\n";
}

}  // namespace mm
