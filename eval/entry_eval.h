#pragma once
// The daemon's own outputs against ground truth: each spool entry's report.json (relative pose
// cam_b_from_cam_a, keyframe times) compared with a TUM-format dataset's groundtruth.txt; a
// walk's entry (kind walk) by its map segment's keyframe poses: the ATE after a Sim(3)
// alignment (Umeyama 1991), as `monomesh eval --walk` reports it.
//
// Keyframe times: with the replay camera, a keyframe's source_time_s is the dataset time. Through
// a real device (v4l2loopback fed by `monomesh feed --log FILE`), it is the driver's
// CLOCK_MONOTONIC timestamp, taken while the frame is written; the feed log (`write_start_s
// write_end_s dataset_time_s` per written frame, CLOCK_MONOTONIC) maps it back to the dataset
// frame whose write interval holds it.
//
// Thread-safety: pure functions; reentrant.

#include <filesystem>
#include <string>
#include <vector>

namespace mm {

/// One frame `monomesh feed` wrote to the device: when the write started and ended
/// (CLOCK_MONOTONIC, s) and the dataset time of the frame.
struct FedFrame {
  double write_start_s = 0, write_end_s = 0, dataset_time_s = 0;
};

/// The feed log's `write_start_s write_end_s dataset_time_s` lines ('#' comments), sorted by
/// write start. On a malformed line returns {} and sets `*error` naming source and line.
std::vector<FedFrame> ParseFeedLog(const std::string& text, const std::string& source_name,
                                   std::string* error);

struct EntryEvalOptions {
  std::filesystem::path spool;     ///< Folder of entries (each with report.json).
  std::filesystem::path dataset;   ///< TUM-format folder with groundtruth.txt.
  std::filesystem::path feed_log;  ///< Optional: `monomesh feed --log` output (device path).
  double feed_slack_s = 0.001;     ///< Slack around a fed frame's write interval.
  [[nodiscard]] std::string Check() const;
};

struct EntryEval {
  std::string entry;           ///< Folder name.
  std::string kind = "pair";   ///< "pair" or "walk" (report.json's kind).
  bool reconstructed = false;  ///< The report says the reconstruction succeeded.
  bool evaluated = false;      ///< Ground truth found for both keyframes.
  std::string problem;         ///< Why not evaluated (or the reconstruction's failure reason).
  double time_a_s = 0, time_b_s = 0;  ///< Dataset times of the keyframes.
  double rot_err_deg = 0;             ///< Angle of R_est^T R_gt.
  double trans_err_deg = 0;           ///< Angle between the translation directions.
  double baseline_m = 0;              ///< Ground-truth distance between the two camera centres.
  double gt_rotation_deg = 0;         ///< Ground-truth rotation angle between the keyframes.
  int mesh_vertices = 0;
  /// A walk: its keyframes (all segments), the map segment's registered keyframes with ground
  /// truth, and their ATE after a Sim(3) alignment (Umeyama) over the path they span.
  struct Walk {
    int keyframes = 0;
    int segments = 0;
    int evaluated_keyframes = 0;
    double ate_rmse_m = 0;
    double ate_max_m = 0;
    double path_length_m = 0;
    double sim3_scale = 0;  ///< Metres per map unit.
    std::string stop_reason;
  } walk;
};

struct EntryEvalResult {
  bool ok = false;  ///< Inputs readable (entries may still fail individually).
  std::string failure_reason;
  std::vector<EntryEval> entries;  ///< Sorted by entry name (= time of creation).
  int evaluated = 0;
  double rot_err_median_deg = 0, rot_err_max_deg = 0;
  double trans_err_median_deg = 0, trans_err_max_deg = 0;
  int walks_evaluated = 0;
  /// The largest of the walks' ATE RMSE as a share of their path length.
  double walk_ate_rel_max = 0;
};

EntryEvalResult EvaluateSpoolEntries(const EntryEvalOptions& options);

/// One line per entry and a summary, for the CLI.
std::string FormatEntryEval(const EntryEvalResult& result);
/// {"summary": {"entries", "evaluated", "rot_err_deg": {"median", "max"}, "trans_err_deg":
/// {...}}, "entries": [...]}.
std::string EntryEvalToJson(const EntryEvalResult& result);

}  // namespace mm
