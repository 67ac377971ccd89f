#include "eval/capture_eval.h"

#include <chrono>
#include <cstdio>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <optional>

#include "base/clock.h"
#include "calib/undistort.h"
#include "dataset/tum.h"
#include "entry/json_text.h"
#include "eval/tum_pairs.h"
#include "recon/epipolar.h"
#include "session/recent_frames.h"

namespace mm {
namespace {

using Clock = std::chrono::steady_clock;

// The key a failure is counted under: the two-view failure's name for a refused B, else how
// the capture ended.
std::string FailureKind(const CaptureSession& session) {
  if (session.end() == CaptureEnd::kRefused && !session.tries().empty()) {
    return TwoViewFailureName(session.tries().back().failure);
  }
  return CaptureEndName(session.end());
}

}  // namespace

std::string CaptureEvalOptions::Check() const {
  if (!(trigger_every_s > 0)) return "trigger_every_s: must be > 0";
  if (std::string p = session.Check(); !p.empty()) return p;
  return pair.Check();
}

CaptureEvalResult EvaluateCaptures(const std::filesystem::path& dataset,
                                   const BouguetCamera& camera, const CaptureEvalOptions& options) {
  CaptureEvalResult result;
  if (const std::string problem = options.Check(); !problem.empty()) {
    result.failure_reason = "options: " + problem;
    return result;
  }
  std::vector<TumFrame> frames;
  std::optional<Trajectory> gt;
  if (std::string missing = MissingGroundTruth(dataset); !missing.empty()) {
    result.failure_reason = missing;
    return result;
  }
  try {
    frames =
        ReadTumList(options.list.empty()
                        ? dataset / "rgb.txt"
                        : (options.list.is_absolute() ? options.list : dataset / options.list));
    gt = Trajectory::Read(dataset / "groundtruth.txt");
  } catch (const DatasetError& e) {
    result.failure_reason = e.what();
    return result;
  }
  if (frames.size() < 2) {
    result.failure_reason = dataset.string() + ": fewer than 2 frames";
    return result;
  }
  result.frames = static_cast<int>(frames.size());
  result.video_s = frames.back().timestamp_s - frames.front().timestamp_s;

  const Undistorter undistorter(camera);
  const BouguetCamera& cam = undistorter.output_camera();
  CaptureSession session(cam.K(), options.session);

  // The worker: A's SIFT from the press on, then one B at a time.
  double worker_free_at = 0.0;
  double result_at = 0.0;
  Features features_a;
  std::vector<SourceView> views_before_a;  // A's corners tracked back, as the worker does.
  RecentFrames recent_frames;              // As the daemon keeps them.
  cv::Mat image_a;
  std::optional<PairReconstruction> pending;
  double pending_b_time = 0.0;
  std::string pending_b_image;
  CaptureEval current;
  bool capture_open = false;
  double next_press = frames.front().timestamp_s;
  bool press_now = true;

  auto latency = [&](double wall_s) {
    return options.worker_latency_s >= 0 ? options.worker_latency_s : wall_s;
  };
  auto finish = [&](bool unfinished) {
    current.unfinished = unfinished;
    current.tries = session.tries();
    if (!current.success && !unfinished) {
      current.failure_reason = session.failure_reason();
      current.failure_kind = FailureKind(session);
    }
    result.captures.push_back(current);
    capture_open = false;
    press_now = true;  // Press again after each result.
  };

  for (size_t i = 0; i < frames.size(); ++i) {
    const double t = frames[i].timestamp_s;
    // 1. A result due by now.
    if (capture_open && pending && t >= result_at) {
      const PairReconstruction& r = *pending;
      const CaptureSession::Step step =
          session.OnResult(r.success, r.geometry.failure, r.failure_reason);
      current.image_b = pending_b_image;
      current.time_b_s = pending_b_time;
      if (step == CaptureSession::Step::kDone) {
        current.success = true;
        current.trigger_to_entry_s = result_at - current.trigger_time_s;
        current.matches = r.matches;
        current.tracks_used = r.tracks_used;
        current.inliers = r.geometry.num_inliers;
        current.track_inliers = r.track_inliers;
        current.points = static_cast<int>(r.geometry.points_in_cam_a.size());
        current.median_triangulation_angle_deg = r.geometry.median_triangulation_angle_deg;
        current.dense_views_between = r.intermediate_views_used - r.views_before_a_used;
        current.dense_views_before_a = r.views_before_a_used;
        if (gt) {
          const auto wa = gt->WorldFromCamAt(current.time_a_s, options.max_gt_dt_s);
          const auto wb = gt->WorldFromCamAt(current.time_b_s, options.max_gt_dt_s);
          if (wa && wb) {
            const Eigen::Isometry3d b_from_a = CamBFromCamA(*wa, *wb);
            current.has_gt = true;
            current.rot_err_deg = RotationErrorDeg(r.geometry.rotation, b_from_a.rotation());
            current.trans_err_deg =
                DirectionErrorDeg(r.geometry.translation, b_from_a.translation());
            current.gt_baseline_m = b_from_a.translation().norm();
          }
        }
      }
      pending.reset();
      if (step == CaptureSession::Step::kDone || step == CaptureSession::Step::kFailed) {
        finish(false);
      }
    }
    const cv::Mat raw = cv::imread(frames[i].path.string(), cv::IMREAD_COLOR);
    if (raw.empty()) {
      result.failure_reason = "cannot read " + frames[i].path.string();
      return result;
    }
    const cv::Mat undistorted = undistorter.Apply(raw);
    const cv::Mat gray = ToGray(undistorted);
    // Kept as the daemon keeps them (A itself is never handed out as a frame before A).
    recent_frames.Add(gray, t);
    // 2. The press.
    if (!capture_open && (press_now || t >= next_press)) {
      press_now = false;
      while (next_press <= t) next_press += options.trigger_every_s;
      current = CaptureEval{};
      current.trigger_time_s = t;
      current.time_a_s = t;
      current.image_a = frames[i].path.filename().string();
      image_a = undistorted.clone();
      session.Start(gray, t);
      const auto start = Clock::now();
      features_a = ExtractKeyframeFeatures(image_a, options.pair);
      views_before_a.clear();
      if (options.pair.mesh_mode == MeshMode::kDense) {
        views_before_a = ViewsBeforeA(gray, recent_frames.BeforeA(t), options.session.gate);
      }
      worker_free_at = t + latency(SecondsSince(start));
      capture_open = true;
      continue;
    }
    if (!capture_open) continue;
    // 3. The gate on this frame.
    const bool can_submit = !pending && t >= worker_free_at;
    const CaptureSession::Step step =
        session.OnFrame(gray, static_cast<uint64_t>(i), t, can_submit);
    if (options.log_gate) {
      const GateDecision& d = session.last_decision();
      char line[400];
      std::snprintf(line, sizeof(line),
                    "  %.3f: %d tracks, %d F / %d H inliers, parallax %.2f deg: %s", t, d.tracks,
                    d.essential_inliers, d.homography_inliers, d.median_parallax_deg,
                    d.reason.c_str());
      current.gate_log.emplace_back(line);
    }
    if (step == CaptureSession::Step::kFailed) {
      current.image_b = frames[i].path.filename().string();
      current.time_b_s = t;
      finish(false);
      continue;
    }
    if (step != CaptureSession::Step::kSubmitB) continue;
    std::vector<TrackCorrespondence> tracks;
    if (options.use_tracks) tracks = session.Tracks();
    std::vector<SourceView> between = session.Between();
    between.insert(between.end(), views_before_a.begin(), views_before_a.end());
    const auto start = Clock::now();
    pending = ReconstructPair(features_a, image_a, undistorted, cam, options.pair, tracks, between);
    current.recon_wall_s = SecondsSince(start);
    result_at = t + latency(current.recon_wall_s);
    worker_free_at = result_at;
    pending_b_time = t;
    pending_b_image = frames[i].path.filename().string();
  }
  if (capture_open) finish(true);

  CaptureEvalSummary& s = result.summary;
  std::vector<double> rot, trans, latency_s;
  int tries = 0;
  for (const CaptureEval& c : result.captures) {
    if (c.unfinished) {
      ++s.unfinished;
      continue;
    }
    ++s.triggers;
    tries += static_cast<int>(c.tries.size());
    if (c.success) {
      ++s.succeeded;
      latency_s.push_back(c.trigger_to_entry_s);
      if (c.has_gt) {
        rot.push_back(c.rot_err_deg);
        trans.push_back(c.trans_err_deg);
      }
    } else {
      ++s.failures[c.failure_kind];
    }
  }
  s.rot_err_median_deg = MedianOf(rot);
  s.trans_err_median_deg = MedianOf(trans);
  s.trigger_to_entry_median_s = MedianOf(latency_s);
  s.tries_mean = s.triggers > 0 ? static_cast<double>(tries) / s.triggers : 0.0;
  result.ok = true;
  return result;
}

std::string FormatCaptureLine(const CaptureEval& c) {
  char line[512];
  if (c.success) {
    std::snprintf(line, sizeof(line),
                  "t=%7.3f  A %s  B %s  ok  rot %.3f deg  trans %.2f deg  %zu tries  "
                  "entry after %.2f s  %d matches + %d tracks -> %d inliers (%d tracks), "
                  "angle %.2f deg, dense views %d between + %d before A",
                  c.trigger_time_s, c.image_a.c_str(), c.image_b.c_str(), c.rot_err_deg,
                  c.trans_err_deg, c.tries.size(), c.trigger_to_entry_s, c.matches, c.tracks_used,
                  c.inliers, c.track_inliers, c.median_triangulation_angle_deg,
                  c.dense_views_between, c.dense_views_before_a);
  } else {
    std::snprintf(line, sizeof(line), "t=%7.3f  A %s  %s  %zu tries  %s", c.trigger_time_s,
                  c.image_a.c_str(), c.unfinished ? "unfinished (video ended)" : "FAILED",
                  c.tries.size(), c.failure_reason.c_str());
  }
  std::string out = line;
  for (const std::string& g : c.gate_log) out += "\n" + g;
  for (const KeyframeBTry& t : c.tries) {
    if (t.accepted) continue;
    if (t.reason.empty()) {
      out += "\n           B still being reconstructed when the video ended";
      continue;
    }
    char tl[512];
    if (t.after_lost_track) {
      std::snprintf(tl, sizeof(tl), "\n           B refused after %.3f s (tracks broke): %s",
                    t.seconds_after_a, t.reason.c_str());
    } else {
      std::snprintf(tl, sizeof(tl),
                    "\n           B refused after %.3f s (gate %.2f deg, %d tracks): %s",
                    t.seconds_after_a, t.gate_parallax_deg, t.tracks, t.reason.c_str());
    }
    out += tl;
  }
  return out;
}

std::string FormatCaptureSummary(const CaptureEvalResult& r) {
  const CaptureEvalSummary& s = r.summary;
  char line[512];
  std::snprintf(line, sizeof(line),
                "captures: %d of %d succeeded (%d unfinished at the end of %.1f s of video), "
                "rotation median %.3f deg, translation median %.2f deg, trigger to entry median "
                "%.2f s, %.2f B tries per capture\n",
                s.succeeded, s.triggers, s.unfinished, r.video_s, s.rot_err_median_deg,
                s.trans_err_median_deg, s.trigger_to_entry_median_s, s.tries_mean);
  std::string out = line;
  for (const auto& [kind, n] : s.failures)
    out += "  failed: " + kind + " x" + std::to_string(n) + "\n";
  return out;
}

std::string CaptureEvalToJson(const CaptureEvalResult& r) {
  nlohmann::json captures = nlohmann::json::array();
  for (const CaptureEval& c : r.captures) {
    nlohmann::json tries = nlohmann::json::array();
    for (const KeyframeBTry& t : c.tries) {
      tries.push_back({{"frame", t.frame_sequence},
                       {"seconds_after_a", t.seconds_after_a},
                       {"gate_parallax_deg", t.gate_parallax_deg},
                       {"tracks", t.tracks},
                       {"after_lost_track", t.after_lost_track},
                       {"accepted", t.accepted},
                       {"failure", TwoViewFailureName(t.failure)},
                       {"reason", t.reason}});
    }
    captures.push_back({{"trigger_time_s", c.trigger_time_s},
                        {"image_a", c.image_a},
                        {"image_b", c.image_b},
                        {"time_a_s", c.time_a_s},
                        {"time_b_s", c.time_b_s},
                        {"success", c.success},
                        {"unfinished", c.unfinished},
                        {"failure_reason", c.failure_reason},
                        {"failure_kind", c.failure_kind},
                        {"b_tries", tries},
                        {"has_gt", c.has_gt},
                        {"rot_err_deg", c.rot_err_deg},
                        {"trans_err_deg", c.trans_err_deg},
                        {"gt_baseline_m", c.gt_baseline_m},
                        {"trigger_to_entry_s", c.trigger_to_entry_s},
                        {"recon_wall_s", c.recon_wall_s},
                        {"matches", c.matches},
                        {"tracks_used", c.tracks_used},
                        {"inliers", c.inliers},
                        {"track_inliers", c.track_inliers},
                        {"points", c.points},
                        {"median_triangulation_angle_deg", c.median_triangulation_angle_deg},
                        {"dense_views_between", c.dense_views_between},
                        {"dense_views_before_a", c.dense_views_before_a}});
  }
  const CaptureEvalSummary& s = r.summary;
  nlohmann::json summary = {{"captures",
                             {{"triggers", s.triggers},
                              {"succeeded", s.succeeded},
                              {"unfinished", s.unfinished},
                              {"rot_err_deg", {{"median", s.rot_err_median_deg}}},
                              {"trans_err_deg", {{"median", s.trans_err_median_deg}}},
                              {"trigger_to_entry_s", {{"median", s.trigger_to_entry_median_s}}},
                              {"b_tries_mean", s.tries_mean},
                              {"failures", s.failures}}},
                            {"video_s", r.video_s},
                            {"frames", r.frames}};
  return JsonText(nlohmann::json{{"captures", captures}, {"summary", summary}}, 2) + "\n";
}

}  // namespace mm
