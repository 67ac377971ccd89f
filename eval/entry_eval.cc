#include "eval/entry_eval.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <locale>
#include <nlohmann/json.hpp>
#include <optional>
#include <sstream>

#include "base/stats.h"
#include "base/text_file.h"
#include "dataset/tum.h"
#include "entry/entry.h"
#include "entry/json_text.h"
#include "entry/walk_entry.h"
#include "eval/walk_eval.h"

namespace mm {

std::vector<FedFrame> ParseFeedLog(const std::string& text, const std::string& source_name,
                                   std::string* error) {
  std::vector<FedFrame> rows;
  std::istringstream in(text);
  std::string line;
  for (int number = 1; std::getline(in, line); ++number) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream s(line);
    s.imbue(std::locale::classic());
    FedFrame f;
    if (!(s >> f.write_start_s >> f.write_end_s >> f.dataset_time_s) ||
        f.write_end_s < f.write_start_s) {
      *error = source_name + ":" + std::to_string(number) +
               ": expected 'write_start_s write_end_s dataset_time_s'";
      return {};
    }
    rows.push_back(f);
  }
  std::sort(rows.begin(), rows.end(),
            [](const FedFrame& a, const FedFrame& b) { return a.write_start_s < b.write_start_s; });
  return rows;
}

namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;

std::vector<FedFrame> ReadFeedLog(const fs::path& file, std::string* error) {
  const std::optional<std::string> text = ReadTextFile(file, kMaxDataFileBytes, error);
  if (!text) return {};
  return ParseFeedLog(*text, file.string(), error);
}

// The dataset time of the fed frame whose write interval (widened by `slack_s`) holds `mono_s`.
std::optional<double> MapFedTime(const std::vector<FedFrame>& log, double mono_s, double slack_s) {
  auto it = std::upper_bound(log.begin(), log.end(), mono_s + slack_s,
                             [](double t, const FedFrame& f) { return t < f.write_start_s; });
  if (it == log.begin()) return std::nullopt;
  --it;  // The last frame whose write started before mono_s + slack.
  if (mono_s > it->write_end_s + slack_s) return std::nullopt;
  return it->dataset_time_s;
}

// A walk entry: the map segment's registered keyframes against the ground truth.
void EvaluateWalkEntry(const fs::path& dir, const Trajectory& gt, const std::vector<FedFrame>& feed,
                       double slack_s, EntryEval* e) {
  e->kind = "walk";
  WalkReport report;
  if (std::string error = ReadWalkReport(dir, &report); !error.empty()) {
    e->problem = error;
    return;
  }
  e->reconstructed = report.success;
  e->walk.keyframes = report.counts.keyframes;
  e->walk.segments = report.counts.segments;
  e->walk.stop_reason = report.stop_reason;
  if (!report.success) {
    e->problem = "walk failed: " + report.failure_reason;
    return;
  }
  std::vector<Eigen::Vector3d> estimated, truth;
  for (const WalkReport::Keyframe& k : report.keyframes) {
    if (!k.registered || k.segment != report.map_segment) continue;
    double t = k.info.source_time_s;
    if (!feed.empty()) {
      const auto mapped = MapFedTime(feed, t, slack_s);
      if (!mapped) {
        e->problem = "keyframe " + std::to_string(k.index) + " (device time " + std::to_string(t) +
                     " s) matches no fed frame in the feed log";
        return;
      }
      t = *mapped;
    }
    const auto world_from_cam = gt.WorldFromCamAt(t);
    if (!world_from_cam) continue;
    const Eigen::Quaterniond q(k.quaternion_wxyz[0], k.quaternion_wxyz[1], k.quaternion_wxyz[2],
                               k.quaternion_wxyz[3]);
    estimated.push_back(-(q.normalized().toRotationMatrix().transpose() * k.translation));
    truth.push_back(world_from_cam->translation());
  }
  e->walk.evaluated_keyframes = static_cast<int>(estimated.size());
  if (estimated.size() < 3) {
    e->problem = "fewer than 3 keyframes of the map segment have ground truth";
    return;
  }
  Eigen::Matrix3Xd source(3, static_cast<Eigen::Index>(estimated.size()));
  Eigen::Matrix3Xd target(3, static_cast<Eigen::Index>(truth.size()));
  for (size_t i = 0; i < estimated.size(); ++i) {
    source.col(static_cast<Eigen::Index>(i)) = estimated[i];
    target.col(static_cast<Eigen::Index>(i)) = truth[i];
    if (i > 0) e->walk.path_length_m += (truth[i] - truth[i - 1]).norm();
  }
  const Eigen::Matrix4d sim3 = AlignSim3(source, target);
  e->walk.sim3_scale = sim3.block<3, 1>(0, 0).norm();
  double sum_sq = 0;
  for (size_t i = 0; i < estimated.size(); ++i) {
    const Eigen::Vector3d aligned = sim3.block<3, 3>(0, 0) * estimated[i] + sim3.block<3, 1>(0, 3);
    const double err = (aligned - truth[i]).norm();
    sum_sq += err * err;
    e->walk.ate_max_m = std::max(e->walk.ate_max_m, err);
  }
  e->walk.ate_rmse_m = std::sqrt(sum_sq / static_cast<double>(estimated.size()));
  e->evaluated = true;
}

}  // namespace

std::string EntryEvalOptions::Check() const {
  if (!fs::is_directory(spool)) return "spool folder " + spool.string() + " does not exist";
  if (!fs::is_regular_file(dataset / "groundtruth.txt")) {
    return "dataset " + dataset.string() + " has no groundtruth.txt";
  }
  if (!feed_log.empty() && !fs::is_regular_file(feed_log)) {
    return "feed log " + feed_log.string() + " does not exist";
  }
  if (!(feed_slack_s >= 0)) return "feed_slack_s must be >= 0";
  return {};
}

EntryEvalResult EvaluateSpoolEntries(const EntryEvalOptions& options) {
  EntryEvalResult result;
  if (std::string problem = options.Check(); !problem.empty()) {
    result.failure_reason = problem;
    return result;
  }
  std::vector<FedFrame> feed;
  if (!options.feed_log.empty()) {
    feed = ReadFeedLog(options.feed_log, &result.failure_reason);
    if (!result.failure_reason.empty()) return result;
  }
  std::optional<Trajectory> gt;
  try {
    gt = Trajectory::Read(options.dataset / "groundtruth.txt");
  } catch (const DatasetError& e) {
    result.failure_reason = e.what();
    return result;
  }
  std::vector<fs::path> entries;
  for (const auto& d : fs::directory_iterator(options.spool)) {
    // Entries only: the spool's temporary folders start with '.', and `latest` is a symlink
    // to an entry already listed.
    if (d.is_directory() && !d.is_symlink() && d.path().filename().string()[0] != '.' &&
        fs::is_regular_file(d.path() / "report.json")) {
      entries.push_back(d.path());
    }
  }
  std::sort(entries.begin(), entries.end());
  std::vector<double> rot, trans;
  for (const fs::path& dir : entries) {
    EntryEval e;
    e.entry = dir.filename().string();
    EntryReport report;
    try {
      std::string kind_error;
      const std::string kind = ReadEntryKind(dir, &kind_error);
      if (kind == "walk") {
        EvaluateWalkEntry(dir, *gt, feed, options.feed_slack_s, &e);
        if (e.evaluated) {
          ++result.walks_evaluated;
          if (e.walk.path_length_m > 0) {
            result.walk_ate_rel_max =
                std::max(result.walk_ate_rel_max, e.walk.ate_rmse_m / e.walk.path_length_m);
          }
        }
        result.entries.push_back(e);
        continue;
      }
      if (std::string error = ReadEntryReport(dir, &report); !error.empty()) {
        e.problem = error;
        result.entries.push_back(e);
        continue;
      }
      e.reconstructed = report.success;
      if (!e.reconstructed) {
        e.problem = "reconstruction failed: " + report.failure_reason;
        result.entries.push_back(e);
        continue;
      }
      double t[2] = {report.keyframe_a.source_time_s, report.keyframe_b.source_time_s};
      const char* names[2] = {"a", "b"};
      for (int k = 0; k < 2; ++k) {
        if (!feed.empty()) {
          const auto mapped = MapFedTime(feed, t[k], options.feed_slack_s);
          if (!mapped) {
            throw std::runtime_error(std::string("keyframe ") + names[k] + " (device time " +
                                     std::to_string(t[k]) +
                                     " s) matches no fed frame in the feed log");
          }
          t[k] = *mapped;
        }
      }
      e.time_a_s = t[0];
      e.time_b_s = t[1];
      const Eigen::Matrix3d& r = report.relative_pose.rotation;
      const Eigen::Vector3d& tr = report.relative_pose.translation;
      e.mesh_vertices = static_cast<int>(report.counts.mesh_vertices);
      const auto pose_a = gt->WorldFromCamAt(e.time_a_s);
      const auto pose_b = gt->WorldFromCamAt(e.time_b_s);
      if (!pose_a || !pose_b) throw std::runtime_error("no ground truth at the keyframe times");
      const Eigen::Isometry3d rel = CamBFromCamA(*pose_a, *pose_b);
      e.rot_err_deg = RotationErrorDeg(r, rel.linear());
      e.trans_err_deg = DirectionErrorDeg(tr, rel.translation());
      e.baseline_m = rel.translation().norm();
      e.gt_rotation_deg = Eigen::AngleAxisd(rel.linear()).angle() * 180.0 / M_PI;
      e.evaluated = true;
      rot.push_back(e.rot_err_deg);
      trans.push_back(e.trans_err_deg);
    } catch (const std::exception& ex) {
      e.problem = (dir / "report.json").string() + ": " + ex.what();
    }
    result.entries.push_back(e);
  }
  result.ok = true;
  result.evaluated = static_cast<int>(rot.size()) + result.walks_evaluated;
  result.rot_err_median_deg = Percentile(rot, 50);
  result.trans_err_median_deg = Percentile(trans, 50);
  result.rot_err_max_deg = rot.empty() ? 0 : *std::max_element(rot.begin(), rot.end());
  result.trans_err_max_deg = trans.empty() ? 0 : *std::max_element(trans.begin(), trans.end());
  return result;
}

std::string FormatEntryEval(const EntryEvalResult& r) {
  std::ostringstream s;
  s.setf(std::ios::fixed);
  s.precision(3);
  for (const EntryEval& e : r.entries) {
    s << e.entry << ": ";
    if (!e.evaluated) {
      s << "not evaluated (" << e.problem << ")\n";
      continue;
    }
    if (e.kind == "walk") {
      s << "walk of " << e.walk.keyframes << " keyframes, " << e.walk.segments << " segments ("
        << e.walk.stop_reason << "): " << e.walk.evaluated_keyframes << " evaluated, ATE RMSE "
        << e.walk.ate_rmse_m << " m over " << e.walk.path_length_m << " m, max " << e.walk.ate_max_m
        << " m, scale " << e.walk.sim3_scale << " m/unit\n";
      continue;
    }
    s << "t " << e.time_a_s << " -> " << e.time_b_s << " s, baseline " << e.baseline_m
      << " m, gt rotation " << e.gt_rotation_deg << " deg: rot err " << e.rot_err_deg
      << " deg, trans dir err " << e.trans_err_deg << " deg, " << e.mesh_vertices
      << " mesh vertices\n";
  }
  if (r.walks_evaluated > 0) {
    s << "walks evaluated: " << r.walks_evaluated << ", largest ATE RMSE / path "
      << 100.0 * r.walk_ate_rel_max << " %\n";
  }
  s << "entries: " << r.entries.size() << ", evaluated " << r.evaluated << "; rot err median "
    << r.rot_err_median_deg << " max " << r.rot_err_max_deg << " deg; trans dir err median "
    << r.trans_err_median_deg << " max " << r.trans_err_max_deg << " deg\n";
  return s.str();
}

std::string EntryEvalToJson(const EntryEvalResult& r) {
  json entries = json::array();
  for (const EntryEval& e : r.entries) {
    json j = {{"entry", e.entry},
              {"kind", e.kind},
              {"reconstructed", e.reconstructed},
              {"evaluated", e.evaluated}};
    if (e.evaluated && e.kind == "walk") {
      j["walk"] = {{"keyframes", e.walk.keyframes},
                   {"segments", e.walk.segments},
                   {"evaluated_keyframes", e.walk.evaluated_keyframes},
                   {"ate_rmse_m", e.walk.ate_rmse_m},
                   {"ate_max_m", e.walk.ate_max_m},
                   {"path_length_m", e.walk.path_length_m},
                   {"sim3_scale", e.walk.sim3_scale},
                   {"stop_reason", e.walk.stop_reason}};
    } else if (e.evaluated) {
      j.update({{"time_a_s", e.time_a_s},
                {"time_b_s", e.time_b_s},
                {"rot_err_deg", e.rot_err_deg},
                {"trans_err_deg", e.trans_err_deg},
                {"baseline_m", e.baseline_m},
                {"gt_rotation_deg", e.gt_rotation_deg},
                {"mesh_vertices", e.mesh_vertices}});
    } else {
      j["problem"] = e.problem;
    }
    entries.push_back(j);
  }
  const json summary = {
      {"entries", r.entries.size()},
      {"evaluated", r.evaluated},
      {"rot_err_deg", {{"median", r.rot_err_median_deg}, {"max", r.rot_err_max_deg}}},
      {"trans_err_deg", {{"median", r.trans_err_median_deg}, {"max", r.trans_err_max_deg}}},
      {"walks_evaluated", r.walks_evaluated},
      {"walk_ate_rel_max", r.walk_ate_rel_max}};
  return JsonText(json({{"summary", summary}, {"entries", entries}}), 2) + "\n";
}

}  // namespace mm
