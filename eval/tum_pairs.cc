#include "eval/tum_pairs.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <map>
#include <nlohmann/json.hpp>
#include <opencv2/core/utility.hpp>
#include <opencv2/imgcodecs.hpp>
#include <optional>
#include <random>

#include "base/clock.h"
#include "calib/undistort.h"
#include "dataset/tum.h"
#include "entry/json_text.h"
#include "eval/mesh_checks.h"

namespace mm {
namespace {

// Relative depth error of the triangulated points against a TUM depth map of frame A, after
// one median scale factor (the reconstruction is up to scale).
void CompareDepth(const PairReconstruction& r, const cv::Mat& depth16, PairEval* out) {
  std::vector<double> ratios, est, gt;
  for (size_t i = 0; i < r.geometry.points_in_cam_a.size() && i < r.point_pixels_a.size(); ++i) {
    const int u = static_cast<int>(std::lround(r.point_pixels_a[i].x()));
    const int v = static_cast<int>(std::lround(r.point_pixels_a[i].y()));
    if (u < 0 || v < 0 || u >= depth16.cols || v >= depth16.rows) continue;
    const uint16_t raw = depth16.at<uint16_t>(v, u);
    if (raw == 0) continue;
    const double d = raw / 5000.0;
    const double z = r.geometry.points_in_cam_a[i].z();
    if (!(z > 0)) continue;
    est.push_back(z);
    gt.push_back(d);
    ratios.push_back(d / z);
  }
  out->depth_points = static_cast<int>(est.size());
  if (est.empty()) return;
  out->has_depth = true;
  out->depth_scale = Percentile(ratios, 50);
  std::vector<double> rel;
  int within = 0;
  for (size_t i = 0; i < est.size(); ++i) {
    const double e = std::abs(out->depth_scale * est[i] - gt[i]) / gt[i];
    rel.push_back(e);
    if (e < 0.10) ++within;
  }
  out->depth_rel_err_median = Percentile(rel, 50);
  out->depth_within_10pct = static_cast<double>(within) / static_cast<double>(est.size());
}

MeshFigures MeshFiguresOf(const MeshDepthEval& e) {
  MeshFigures f;
  f.valid = e.success;
  f.coverage = e.coverage;
  f.depth_rel_err_median = e.median_rel_err;
  f.depth_rel_err_p90 = e.p90_rel_err;
  f.flying = e.flying;
  return f;
}

EvalSummary Summarize(const std::vector<PairEval>& pairs) {
  EvalSummary s;
  s.pairs = static_cast<int>(pairs.size());
  std::vector<double> rot, trans, time, after_b, cpu, cpu_after_b, depth, within;
  for (const PairEval& p : pairs) {
    time.push_back(p.time_two_images_s);
    after_b.push_back(p.time_after_b_s);
    cpu.push_back(p.cpu_two_images_s);
    cpu_after_b.push_back(p.cpu_after_b_s);
    if (!p.success) continue;
    ++s.succeeded;
    if (p.has_gt) {
      rot.push_back(p.rot_err_deg);
      trans.push_back(p.trans_err_deg);
    }
    if (p.has_depth) {
      depth.push_back(p.depth_rel_err_median);
      within.push_back(p.depth_within_10pct);
    }
  }
  s.rot_err_median_deg = Percentile(rot, 50);
  s.rot_err_p90_deg = Percentile(rot, 90);
  s.trans_err_median_deg = Percentile(trans, 50);
  s.trans_err_p90_deg = Percentile(trans, 90);
  s.time_median_s = Percentile(time, 50);
  s.time_after_b_median_s = Percentile(after_b, 50);
  s.cpu_median_s = Percentile(cpu, 50);
  s.cpu_after_b_median_s = Percentile(cpu_after_b, 50);
  std::vector<double> mesh_cov, mesh_med, mesh_p90, mesh_flying;
  for (const PairEval& p : pairs) {
    if (!p.mesh.valid) continue;
    mesh_cov.push_back(p.mesh.coverage);
    mesh_med.push_back(p.mesh.depth_rel_err_median);
    mesh_p90.push_back(p.mesh.depth_rel_err_p90);
    mesh_flying.push_back(p.mesh.flying);
  }
  s.mesh_pairs = static_cast<int>(mesh_cov.size());
  s.mesh_coverage = Percentile(mesh_cov, 50);
  s.mesh_depth_rel_err_median = Percentile(mesh_med, 50);
  s.mesh_depth_rel_err_p90 = Percentile(mesh_p90, 50);
  s.mesh_flying = Percentile(mesh_flying, 50);
  std::vector<double> scale_err;
  for (const PairEval& p : pairs) {
    if (!p.success || !p.has_scale) continue;
    ++s.scale_pairs;
    if (p.scale.scaled() && p.true_metres_per_unit > 0) scale_err.push_back(p.scale_rel_err);
  }
  s.scaled_pairs = static_cast<int>(scale_err.size());
  s.scale_rel_err_median = Percentile(scale_err, 50);
  s.scale_rel_err_p90 = Percentile(scale_err, 90);
  s.depth_pairs = static_cast<int>(depth.size());
  s.depth_rel_err_median = Percentile(depth, 50);
  double sum = 0;
  for (double w : within) sum += w;
  s.depth_within_10pct = within.empty() ? 0.0 : sum / static_cast<double>(within.size());
  return s;
}

}  // namespace

std::string MissingGroundTruth(const std::filesystem::path& dataset) {
  const std::filesystem::path file = dataset / "groundtruth.txt";
  if (std::filesystem::is_regular_file(file)) return {};
  return file.string() + ": missing; the evaluation compares with the dataset's ground truth " +
         "(TUM format: timestamp tx ty tz qx qy qz qw)";
}

std::string EvalOptions::Check() const {
  if (step < 1) return "step: must be >= 1";
  if (threads < 0) return "threads: must be >= 0";
  if (!(max_depth_dt_s >= 0)) return "max_depth_dt_s: must be >= 0";
  return pair.Check();
}

EvalResult EvaluateTumPairs(const std::filesystem::path& dataset, const BouguetCamera& camera,
                            const EvalOptions& options) {
  EvalResult result;
  if (const std::string problem = options.Check(); !problem.empty()) {
    result.failure_reason = "options: " + problem;
    return result;
  }
  TumSequence sequence;
  // An evaluation without ground truth has nothing to compare with: without this, every error
  // printed 0.000 deg and every reconstructed pair counted as a success.
  if (std::string missing = MissingGroundTruth(dataset); !missing.empty()) {
    result.failure_reason = missing;
    return result;
  }
  try {
    sequence = ReadTumSequence(dataset, options.list);
  } catch (const DatasetError& e) {
    result.failure_reason = e.what();
    return result;
  }
  const std::vector<TumFrame>& frames = sequence.frames;
  const std::vector<TumFrame>& depth_frames = sequence.depth_frames;
  const Trajectory& trajectory = sequence.trajectory;
  if (options.threads > 0) cv::setNumThreads(options.threads);

  BouguetCamera sized = camera;
  std::optional<Undistorter> undistorter;
  const BouguetCamera* used = &sized;
  auto load = [&](const std::filesystem::path& path) -> cv::Mat {
    cv::Mat image = cv::imread(path.string(), cv::IMREAD_COLOR);
    if (image.empty()) return image;
    if (sized.width == 0) {
      sized.width = image.cols;
      sized.height = image.rows;
    }
    if (sized.HasDistortion()) {
      if (!undistorter) undistorter.emplace(sized);
      used = &undistorter->output_camera();
      return undistorter->Apply(image);
    }
    return image;
  };

  // Each frame decoded (and undistorted) once, and its SIFT computed once with the time it
  // took: a frame is B, A, a middle frame and a view before A of several pairs. Frames older
  // than the current A's horizon are dropped.
  struct CachedFrame {
    cv::Mat image;
    std::optional<Features> features;
    double sift_wall_s = 0, sift_cpu_s = 0;
  };
  std::map<size_t, CachedFrame> cache;
  const auto frame_at = [&](size_t k) -> CachedFrame& {
    auto it = cache.find(k);
    if (it == cache.end()) {
      it = cache.emplace(k, CachedFrame{load(frames[k].path), std::nullopt}).first;
    }
    return it->second;
  };
  const auto features_of = [&](size_t k) -> const CachedFrame& {
    CachedFrame& f = frame_at(k);
    if (!f.features) {
      const double cpu_start = ProcessCpuSeconds();
      const auto wall_start = std::chrono::steady_clock::now();
      f.features = ExtractKeyframeFeatures(f.image, options.pair);
      f.sift_wall_s =
          std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();
      f.sift_cpu_s = ProcessCpuSeconds() - cpu_start;
    }
    return f;
  };
  const double horizon_s = options.views_before_a ? options.recent_frames.horizon_s() : 0.0;

  const auto step = static_cast<size_t>(options.step);
  for (size_t i = 0; i + step < frames.size(); ++i) {
    while (!cache.empty() && cache.begin()->first < i &&
           frames[cache.begin()->first].timestamp_s < frames[i].timestamp_s - horizon_s) {
      cache.erase(cache.begin());
    }
    PairEval p;
    p.index_a = static_cast<int>(i);
    p.index_b = static_cast<int>(i + step);
    p.time_a_s = frames[i].timestamp_s;
    p.time_b_s = frames[i + step].timestamp_s;
    p.image_a = frames[i].path.string();
    p.image_b = frames[i + step].path.string();
    const cv::Mat image_a = frame_at(i).image;
    const cv::Mat image_b = frame_at(i + step).image;
    if (image_a.empty() || image_b.empty()) {
      p.failure_reason = "cannot read " + (image_a.empty() ? p.image_a : p.image_b);
      result.pairs.push_back(p);
      continue;
    }
    // The pair is reconstructed once, from A's features (the appliance's case: A's SIFT runs
    // while it waits for B); the time from two images is A's SIFT plus that.
    const CachedFrame& a = features_of(i);
    const Features& features_a = *a.features;
    // The middle frames between A and B, matched to A (outside the timing: the appliance has
    // the gate's tracks); the reconstruction takes the one nearest halfway.
    std::vector<SourceView> between;
    if (options.intermediate_view && options.pair.mesh_mode == MeshMode::kDense) {
      // The middle frame (both middle ones for an odd step).
      for (size_t m = i + step / 2; m <= i + (step + 1) / 2 && m > i && m < i + step; ++m) {
        const CachedFrame& middle = frame_at(m);
        if (!middle.image.empty()) {
          between.push_back(
              MatchSourceView(features_a, middle.image, *features_of(m).features, options.pair));
        }
      }
    }
    if (options.views_before_a && options.pair.mesh_mode == MeshMode::kDense) {
      // The frames the daemon would hold before A (it tracks A's corners back to them; here,
      // as for the frames between, SIFT matches with A stand in for the tracks).
      RecentFrames recent(options.recent_frames);
      std::map<double, size_t> index_at;
      for (size_t j = 0; j < i; ++j) {
        // Only the frames it would keep are read.
        if (frames[j].timestamp_s < frames[i].timestamp_s - horizon_s ||
            !recent.Keeps(frames[j].timestamp_s)) {
          continue;
        }
        const cv::Mat& image_j = frame_at(j).image;
        if (!image_j.empty()) {
          recent.Add(image_j, frames[j].timestamp_s);
          index_at[frames[j].timestamp_s] = j;
        }
      }
      for (const double time_before : recent.BeforeATimes(frames[i].timestamp_s)) {
        const size_t j = index_at.at(time_before);
        between.push_back(
            MatchSourceView(features_a, frame_at(j).image, *features_of(j).features, options.pair));
      }
    }
    const double features_a_wall_s = a.sift_wall_s;
    const double features_a_cpu_s = a.sift_cpu_s;
    const double cpu_start = ProcessCpuSeconds();
    PairReconstruction r =
        ReconstructPair(features_a, image_a, image_b, *used, options.pair, {}, between);
    p.cpu_after_b_s = ProcessCpuSeconds() - cpu_start;
    p.cpu_two_images_s = features_a_cpu_s + p.cpu_after_b_s;
    p.time_after_b_s = r.times.total_s();
    r.times.features_a_s = features_a_wall_s;
    p.success = r.success;
    p.failure_reason = r.failure_reason;
    p.classification = PairKindName(r.geometry.classification.kind);
    p.features_a = r.features_a;
    p.features_b = r.features_b;
    p.matches = r.matches;
    p.inliers = r.geometry.num_inliers;
    p.points = static_cast<int>(r.geometry.points_in_cam_a.size());
    p.median_triangulation_angle_deg = r.geometry.median_triangulation_angle_deg;
    p.reprojection_rms_px = r.geometry.reprojection_rms_px;
    p.times = r.times;
    p.geometry_times = r.geometry.times;
    p.time_two_images_s = r.times.total_s();
    const auto wa = trajectory.WorldFromCamAt(p.time_a_s, options.max_gt_dt_s);
    const auto wb = trajectory.WorldFromCamAt(p.time_b_s, options.max_gt_dt_s);
    if (wa && wb) {
      const Eigen::Isometry3d gt = CamBFromCamA(*wa, *wb);
      p.has_gt = true;
      p.gt_rotation_deg = RotationErrorDeg(Eigen::Matrix3d::Identity(), gt.linear());
      p.gt_baseline_m = gt.translation().norm();
      p.rot_err_deg = RotationErrorDeg(r.geometry.rotation, gt.linear());
      p.trans_err_deg = DirectionErrorDeg(r.geometry.translation, gt.translation());
    }
    if (r.success && options.scale.source != ScaleSource::kNone) {
      p.has_scale = true;
      ScaleInputs in;
      in.baseline_units = r.geometry.translation.norm();
      in.points_in_a = r.SurfacePointsInA();
      in.gray_a = ToGray(image_a);
      in.K = used->K();
      if (wa && wb) {
        // The robot's odometry, simulated: the true camera centres with noise.
        std::mt19937 rng(options.odom_seed + static_cast<uint32_t>(p.index_a));
        std::normal_distribution<double> noise(0.0, options.odom_noise_m);
        const auto noisy = [&](const Eigen::Vector3d& c) {
          return options.odom_noise_m > 0
                     ? Eigen::Vector3d(c + Eigen::Vector3d(noise(rng), noise(rng), noise(rng)))
                     : c;
        };
        in.odometry_a_m = noisy(wa->translation());
        in.odometry_b_m = noisy(wb->translation());
        p.true_metres_per_unit = p.gt_baseline_m / in.baseline_units;
      } else {
        in.odometry_why_not = "no ground truth to simulate odometry from";
      }
      p.scale = EstimateScale(in, options.scale);
      if (p.scale.scaled() && p.true_metres_per_unit > 0) {
        p.scale_rel_err = std::abs(p.scale.metres_per_unit / p.true_metres_per_unit - 1.0);
      }
    }
    if (r.success && !depth_frames.empty()) {
      const int d = NearestFrame(depth_frames, p.time_a_s, options.max_depth_dt_s);
      if (d >= 0) {
        cv::Mat depth =
            cv::imread(depth_frames[static_cast<size_t>(d)].path.string(), cv::IMREAD_UNCHANGED);
        if (depth.type() == CV_16UC1 && depth.size() == image_a.size()) {
          // The depth image is seen through the dataset's (distorted) camera; the
          // reconstruction through the undistorted one: bring the depth there, unblended.
          if (undistorter) depth = undistorter->ApplyNearest(depth);
          CompareDepth(r, depth, &p);
          if (options.mesh_figures) {
            cv::Mat depth_m;
            depth.convertTo(depth_m, CV_32F, 1.0 / 5000.0);  // TUM: depth[m] = value / 5000.
            p.mesh = MeshFiguresOf(EvaluatePairMesh(r, used->K(), depth_m));
            p.mesh.mode = MeshModeName(r.mesh_mode);
            p.mesh.vertices = static_cast<int>(r.mesh.vertices.size());
            p.mesh.triangles = static_cast<int>(r.mesh.triangles.size());
            p.mesh.intermediate_views = r.intermediate_views_used;
            p.mesh.views_before_a = r.views_before_a_used;
            p.mesh.views_left_out = r.intermediate_failures;
          }
        }
      }
    }
    result.pairs.push_back(p);
  }
  if (!result.pairs.empty() && std::none_of(result.pairs.begin(), result.pairs.end(),
                                            [](const PairEval& p) { return p.has_gt; })) {
    result.failure_reason = (dataset / "groundtruth.txt").string() + ": no pose within " +
                            std::to_string(options.max_gt_dt_s) +
                            " s of any pair's frames; nothing to compare with";
    return result;
  }
  result.summary = Summarize(result.pairs);
  result.ok = true;
  return result;
}

std::string FormatPairLine(const PairEval& p) {
  char buf[512];
  std::snprintf(buf, sizeof(buf),
                "pair %2d-%-2d %-4s rot %6.3f deg  trans %6.3f deg  inliers %4d  points %4d  "
                "angle %5.2f deg  time %.3f s (after B %.3f s: sift %.3f match %.3f geom %.3f "
                "dense %.3f mesh %.3f; CPU %.3f / %.3f s)",
                p.index_a, p.index_b, p.success ? "ok" : "FAIL", p.rot_err_deg, p.trans_err_deg,
                p.inliers, p.points, p.median_triangulation_angle_deg, p.time_two_images_s,
                p.time_after_b_s, p.times.features_b_s, p.times.matching_s, p.times.geometry_s,
                p.times.dense_s, p.times.meshing_s, p.cpu_two_images_s, p.cpu_after_b_s);
  std::string line = buf;
  if (p.has_depth) {
    std::snprintf(buf, sizeof(buf), "  depth err %.2f %% (%.1f %% within 10 %%, %d pts)",
                  100 * p.depth_rel_err_median, 100 * p.depth_within_10pct, p.depth_points);
    line += buf;
  }
  if (p.mesh.valid) {
    std::snprintf(buf, sizeof(buf),
                  "  mesh %s (%d vertices, %d views between, %d before A): coverage %.1f %%, "
                  "depth err %.2f %% (p90 %.1f %%, flying %.1f %%)",
                  p.mesh.mode.c_str(), p.mesh.vertices,
                  p.mesh.intermediate_views - p.mesh.views_before_a, p.mesh.views_before_a,
                  100 * p.mesh.coverage, 100 * p.mesh.depth_rel_err_median,
                  100 * p.mesh.depth_rel_err_p90, 100 * p.mesh.flying);
    line += buf;
  }
  if (p.has_scale) {
    if (p.scale.scaled()) {
      std::snprintf(buf, sizeof(buf), "  scale %s %.4f m/unit (true %.4f, err %.2f %%)",
                    ScaleSourceName(p.scale.source), p.scale.metres_per_unit,
                    p.true_metres_per_unit, 100 * p.scale_rel_err);
      line += buf;
    } else {
      line += "  unscaled (" + p.scale.why_not + ")";
    }
  }
  if (!p.success) line += "  [" + p.classification + ": " + p.failure_reason + "]";
  return line;
}

std::string FormatSummary(const EvalSummary& s) {
  char buf[768];
  std::snprintf(buf, sizeof(buf),
                "summary: %d/%d pairs succeeded\n"
                "  rotation error    median %.3f deg  p90 %.3f deg\n"
                "  translation error median %.3f deg  p90 %.3f deg\n"
                "  time per pair     median %.3f s (two images), %.3f s (after B) wall;"
                " %.3f s / %.3f s CPU\n",
                s.succeeded, s.pairs, s.rot_err_median_deg, s.rot_err_p90_deg,
                s.trans_err_median_deg, s.trans_err_p90_deg, s.time_median_s,
                s.time_after_b_median_s, s.cpu_median_s, s.cpu_after_b_median_s);
  std::string out = buf;
  if (s.depth_pairs > 0) {
    std::snprintf(buf, sizeof(buf),
                  "  point depth error median %.2f %% (%.1f %% within 10 %%) over %d pair(s)\n",
                  100 * s.depth_rel_err_median, 100 * s.depth_within_10pct, s.depth_pairs);
    out += buf;
  }
  if (s.mesh_pairs > 0) {
    std::snprintf(buf, sizeof(buf),
                  "  mesh depth        coverage %.1f %%, error median %.2f %%, p90 %.1f %%, "
                  "flying %.1f %% over %d pair(s)\n",
                  100 * s.mesh_coverage, 100 * s.mesh_depth_rel_err_median,
                  100 * s.mesh_depth_rel_err_p90, 100 * s.mesh_flying, s.mesh_pairs);
    out += buf;
  }
  if (s.scale_pairs > 0) {
    std::snprintf(buf, sizeof(buf),
                  "  metric scale      error median %.2f %%, p90 %.2f %% over %d scaled pair(s) of "
                  "%d\n",
                  100 * s.scale_rel_err_median, 100 * s.scale_rel_err_p90, s.scaled_pairs,
                  s.scale_pairs);
    out += buf;
  }
  return out;
}

std::string EvalToJson(const EvalResult& result) {
  using json = nlohmann::json;
  const EvalSummary& s = result.summary;
  json summary = {
      {"pairs", s.pairs},
      {"succeeded", s.succeeded},
      {"rot_err_deg", {{"median", s.rot_err_median_deg}, {"p90", s.rot_err_p90_deg}}},
      {"trans_err_deg", {{"median", s.trans_err_median_deg}, {"p90", s.trans_err_p90_deg}}},
      {"time_s",
       {{"median", s.time_median_s},
        {"median_after_b", s.time_after_b_median_s},
        {"cpu_median", s.cpu_median_s},
        {"cpu_median_after_b", s.cpu_after_b_median_s}}}};
  if (s.depth_pairs > 0) {
    summary["point_depth_rel_err"] = {{"median", s.depth_rel_err_median},
                                      {"within_10pct", s.depth_within_10pct},
                                      {"pairs", s.depth_pairs}};
  } else {
    summary["point_depth_rel_err"] = {{"median", nullptr}, {"within_10pct", nullptr}};
  }
  if (s.scale_pairs > 0) {
    summary["scale"] = {{"pairs", s.scaled_pairs},
                        {"asked", s.scale_pairs},
                        {"rel_err_median", s.scale_rel_err_median},
                        {"rel_err_p90", s.scale_rel_err_p90}};
  }
  if (s.mesh_pairs > 0) {
    summary["mesh"] = {
        {"coverage", s.mesh_coverage},
        {"depth_rel_err",
         {{"median", s.mesh_depth_rel_err_median}, {"p90", s.mesh_depth_rel_err_p90}}},
        {"flying", s.mesh_flying},
        {"pairs", s.mesh_pairs}};
  }
  json pairs = json::array();
  for (const PairEval& p : result.pairs) {
    json j = {{"a", p.index_a},
              {"b", p.index_b},
              {"image_a", p.image_a},
              {"image_b", p.image_b},
              {"success", p.success},
              {"failure_reason", p.failure_reason},
              {"classification", p.classification},
              {"features_a", p.features_a},
              {"features_b", p.features_b},
              {"matches", p.matches},
              {"inliers", p.inliers},
              {"points", p.points},
              {"median_triangulation_angle_deg", p.median_triangulation_angle_deg},
              {"reprojection_rms_px", p.reprojection_rms_px},
              {"time_s",
               {{"total", p.time_two_images_s},
                {"after_b", p.time_after_b_s},
                {"cpu_total", p.cpu_two_images_s},
                {"cpu_after_b", p.cpu_after_b_s},
                {"features_a", p.times.features_a_s},
                {"features_b", p.times.features_b_s},
                {"matching", p.times.matching_s},
                {"geometry", p.times.geometry_s},
                {"dense", p.times.dense_s},
                {"meshing", p.times.meshing_s},
                {"geometry_split",
                 {{"ransac_f", p.geometry_times.ransac_f_s},
                  {"ransac_h", p.geometry_times.ransac_h_s},
                  {"pose", p.geometry_times.pose_s},
                  {"triangulation", p.geometry_times.triangulation_s},
                  {"bundle_adjustment", p.geometry_times.bundle_s}}}}}};
    if (p.has_gt) {
      j["rot_err_deg"] = p.rot_err_deg;
      j["trans_err_deg"] = p.trans_err_deg;
      j["gt_rotation_deg"] = p.gt_rotation_deg;
      j["gt_baseline_m"] = p.gt_baseline_m;
    }
    if (p.has_depth) {
      j["point_depth_rel_err"] = {{"median", p.depth_rel_err_median},
                                  {"within_10pct", p.depth_within_10pct},
                                  {"points", p.depth_points}};
    }
    if (p.has_scale) {
      json scale = {{"source", ScaleSourceName(p.scale.source)},
                    {"metres_per_unit", p.scale.metres_per_unit},
                    {"uncertainty_rel", p.scale.uncertainty_rel},
                    {"why_not", p.scale.why_not}};
      if (p.true_metres_per_unit > 0) {
        scale["true_metres_per_unit"] = p.true_metres_per_unit;
        if (p.scale.scaled()) scale["rel_err"] = p.scale_rel_err;
      }
      // What the floor source saw, for finding why a pair is off (camera A's frame).
      const auto vec = [](const Eigen::Vector3d& v) { return json::array({v.x(), v.y(), v.z()}); };
      const VerticalVanishingPoint& vp = p.scale.vertical;
      scale["vertical"] = {{"found", vp.found},
                           {"up_in_cam", vec(vp.up_in_cam)},
                           {"segments", vp.segments},
                           {"inliers", vp.inliers},
                           {"horizontal_inliers", vp.horizontal_inliers}};
      scale["room"] = {{"found", p.scale.room.found},
                       {"up_in_cam", vec(p.scale.room.up_in_cam)},
                       {"walls", p.scale.room.walls},
                       {"horizontal_planes", p.scale.room.horizontal_planes},
                       {"rms_residual_rel", p.scale.room.rms_residual_rel}};
      const FloorPlane& floor = p.scale.floor;
      scale["floor"] = {{"found", floor.found},
                        {"normal_in_cam", vec(floor.normal)},
                        {"distance", floor.distance},
                        {"inliers", floor.inliers},
                        {"normal_angle_deg", floor.normal_angle_deg}};
      j["scale"] = std::move(scale);
    }
    if (p.mesh.valid) {
      j["mesh"] = {{"coverage", p.mesh.coverage},
                   {"depth_rel_err",
                    {{"median", p.mesh.depth_rel_err_median}, {"p90", p.mesh.depth_rel_err_p90}}},
                   {"flying", p.mesh.flying},
                   {"mode", p.mesh.mode},
                   {"vertices", p.mesh.vertices},
                   {"triangles", p.mesh.triangles},
                   {"intermediate_views", p.mesh.intermediate_views},
                   {"views_before_a", p.mesh.views_before_a},
                   {"views_left_out", p.mesh.views_left_out}};
    }
    pairs.push_back(std::move(j));
  }
  return JsonText(json{{"summary", summary}, {"pairs", pairs}}, 2) + "\n";
}

}  // namespace mm
