#pragma once
// `monomesh eval --captures`: a continuous TUM-format sequence (rgb.txt, groundtruth.txt)
// played at its recorded rate through the daemon's own capture logic (CaptureSession: the
// keyframe gate, the B tries) and reconstruction (ReconstructPair with A's features computed at
// the trigger, as the daemon's worker does), in simulated time: frames are taken at their
// timestamps, and the reconstruction occupies the worker for its measured wall time (or a
// fixed latency), during which the gate keeps tracking and no B can be handed over. Capture is
// pressed at the first frame, then every `trigger_every_s` of video and at the first frame
// after each result (a press while a capture is open is refused, as in the daemon). Each
// capture is compared with the ground truth (relative pose of the keyframes).
//
// Thread-safety: pure function; reentrant.

#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include "calib/camera_model.h"
#include "recon/pipeline.h"
#include "session/capture_session.h"

namespace mm {

struct CaptureEvalOptions {
  std::filesystem::path list;     ///< Image list; empty: <dataset>/rgb.txt.
  CaptureSessionOptions session;  ///< The daemon's [keyframes] settings.
  PairOptions pair;               ///< The daemon's [recon] settings.
  double trigger_every_s = 2.0;   ///< Press capture this often (video time).
  bool use_tracks = true;         ///< The gate's tracks join the SIFT matches.
  /// < 0: the reconstruction takes its measured wall time of video; >= 0: this fixed time
  /// (deterministic runs).
  double worker_latency_s = -1.0;
  double max_gt_dt_s = 0.1;  ///< Ground-truth extrapolation limit.
  bool log_gate = false;     ///< Keep the gate's decision on every frame (CaptureEval::gate_log).
  [[nodiscard]] std::string Check() const;
};

struct CaptureEval {
  double trigger_time_s = 0.0;   ///< Video time of the press (= keyframe A's frame).
  std::string image_a, image_b;  ///< B: of the accepted (or last tried) keyframe.
  double time_a_s = 0.0, time_b_s = 0.0;
  bool success = false;
  bool unfinished = false;  ///< The video ended before the capture did (not counted).
  std::string failure_reason;
  std::string failure_kind;  ///< A short key for the summary ("no_parallax", "lost_track", ...).
  std::vector<KeyframeBTry> tries;
  bool has_gt = false;
  double rot_err_deg = 0.0, trans_err_deg = 0.0;  ///< Of the accepted pair.
  double gt_baseline_m = 0.0;
  double trigger_to_entry_s = 0.0;  ///< Video time from the press to the reconstruction's end.
  double recon_wall_s = 0.0;        ///< Wall time of the accepted reconstruction.
  int matches = 0, tracks_used = 0, inliers = 0, track_inliers = 0, points = 0;
  double median_triangulation_angle_deg = 0.0;
  /// Dense mode: source views the sweep used beside B, between A and B and before A.
  int dense_views_between = 0, dense_views_before_a = 0;
  std::vector<std::string> gate_log;  ///< With log_gate: one line per frame.
};

struct CaptureEvalSummary {
  int triggers = 0;  ///< Finished captures (unfinished ones not counted).
  int succeeded = 0;
  int unfinished = 0;
  double rot_err_median_deg = 0.0, trans_err_median_deg = 0.0;  ///< Over succeeded captures.
  double trigger_to_entry_median_s = 0.0;
  double tries_mean = 0.0;              ///< B reconstructions per finished capture.
  std::map<std::string, int> failures;  ///< failure_kind -> count.
};

struct CaptureEvalResult {
  bool ok = false;  ///< False: the dataset could not be read.
  std::string failure_reason;
  double video_s = 0.0;
  int frames = 0;
  std::vector<CaptureEval> captures;
  CaptureEvalSummary summary;
};

CaptureEvalResult EvaluateCaptures(const std::filesystem::path& dataset,
                                   const BouguetCamera& camera, const CaptureEvalOptions& options);

std::string FormatCaptureLine(const CaptureEval& c);
std::string FormatCaptureSummary(const CaptureEvalResult& r);
/// {"captures": [...], "summary": {"captures": {triggers, succeeded, unfinished,
/// rot_err_deg.median, trans_err_deg.median, trigger_to_entry_s.median, failures}}}.
std::string CaptureEvalToJson(const CaptureEvalResult& r);

}  // namespace mm
