// `monomesh eval --dataset DIR --calib C [--list FILE] [--step N] [--json FILE]`: run the
// two-view reconstruction on every pair (i, i+N) of a TUM-format folder and compare with its
// ground truth (eval/tum_pairs.h holds the logic).
// `monomesh eval --captures --dataset DIR --calib C [--trigger-every S] [--json FILE]`: play a
// continuous sequence through the daemon's gate and worker in simulated time and press capture
// (eval/capture_eval.h).
// `monomesh eval --dataset DIR --spool SPOOL [--feed-log FILE] [--json FILE]`: instead, compare
// the daemon's spool entries (their report.json) with the dataset's ground truth
// (eval/entry_eval.h).
// `monomesh eval --walk --dataset DIR --calib C [--list FILE] [--every-frame] [--json FILE]`:
// run a walk over the sequence and compare its keyframe poses with the ground truth
// (eval/walk_eval.h).

#include <algorithm>
#include <fstream>
#include <iostream>
#include <string>
#include <vector>

#include "calib/calib_io.h"
#include "cli/commands.h"
#include "eval/capture_eval.h"
#include "eval/entry_eval.h"
#include "eval/tum_pairs.h"
#include "eval/walk_eval.h"

namespace mm::cli {
namespace {

// Writes `text` to `path` unless it is empty: 0, or 1 after naming the file it could not write.
int WriteJson(const std::string& path, const std::string& text) {
  if (path.empty()) return 0;
  std::ofstream out(path);
  out << text;
  if (!out) {
    std::cerr << "monomesh eval: cannot write " << path << "\n";
    return 1;
  }
  return 0;
}

struct EvalArgs {
  std::string dataset, calib, list, json, spool, feed_log;
  int step = 1;
  int threads = 1;
  int first_octave = EvalOptions{}.pair.sift.first_octave;
  int max_features = EvalOptions{}.pair.sift.max_features;
  double ratio = EvalOptions{}.pair.match.ratio;
  double contrast = EvalOptions{}.pair.sift.contrast_threshold;
  double ransac_px = EvalOptions{}.pair.two_view.ransac_threshold_px;
  double huber_px = EvalOptions{}.pair.two_view.bundle.huber_px;
  int octave_layers = EvalOptions{}.pair.sift.octave_layers;
  double resize = EvalOptions{}.pair.sift.resize_factor;
  unsigned seed = EvalOptions{}.pair.two_view.seed;
  bool lo_ransac = EvalOptions{}.pair.two_view.lo_ransac;
  bool refine_points = EvalOptions{}.pair.refinement.enabled;
  std::string sift_impl = SiftImplName(EvalOptions{}.pair.sift.impl);
  bool quiet = false;
  bool captures = false;
  bool walk = false;
  bool every_frame = false;
  bool resize_given = false;  ///< --sift-resize on the command line (the walk has its own default).
  int walk_window = WalkOptions{}.window;
  bool walk_refine = WalkEvalOptions{}.refine;
  int match_keyframes = WalkOptions{}.match_keyframes;
  bool log_gate = false;
  double trigger_every_s = CaptureEvalOptions{}.trigger_every_s;
  double parallax_deg = KeyframeGateOptions{}.parallax_deg;
  double min_parallax_deg = TwoViewOptions{}.min_median_triangulation_angle_deg;
  double timeout_s = CaptureSessionOptions{}.timeout_s;
  bool use_tracks = CaptureEvalOptions{}.use_tracks;
  double worker_latency_s = CaptureEvalOptions{}.worker_latency_s;
  std::string mesh_mode = MeshModeName(EvalOptions{}.pair.mesh_mode);
  bool frame_between = EvalOptions{}.intermediate_view;
  bool frames_before_a = EvalOptions{}.views_before_a;
  std::string scale_source = "none";
  double odom_noise_m = 0.0;
  unsigned odom_seed = EvalOptions{}.odom_seed;
  double camera_height_m = 0.0;
  double camera_pitch_deg = 0.0;
};

int RunEntryEval(const EvalArgs& args) {
  const EntryEvalResult result = EvaluateSpoolEntries(
      {.spool = args.spool, .dataset = args.dataset, .feed_log = args.feed_log});
  if (!result.ok) {
    std::cerr << "monomesh eval: " << result.failure_reason << "\n";
    return 1;
  }
  std::cout << FormatEntryEval(result);
  return WriteJson(args.json, EntryEvalToJson(result));
}

int RunCaptureEval(const EvalArgs& args, const BouguetCamera& camera, const PairOptions& pair) {
  CaptureEvalOptions options;
  options.list = args.list;
  options.pair = pair;
  options.pair.two_view.min_median_triangulation_angle_deg = args.min_parallax_deg;
  options.session.gate.parallax_deg = args.parallax_deg;
  options.session.gate.two_view = options.pair.two_view;
  options.session.timeout_s = args.timeout_s;
  options.trigger_every_s = args.trigger_every_s;
  options.use_tracks = args.use_tracks;
  options.worker_latency_s = args.worker_latency_s;
  options.log_gate = args.log_gate;
  if (const std::string problem = options.Check(); !problem.empty()) {
    std::cerr << "monomesh eval: " << problem << "\n";
    return 2;
  }
  const CaptureEvalResult result = EvaluateCaptures(args.dataset, camera, options);
  if (!result.ok) {
    std::cerr << "monomesh eval: " << result.failure_reason << "\n";
    return 1;
  }
  if (!args.quiet) {
    for (const CaptureEval& c : result.captures) std::cout << FormatCaptureLine(c) << "\n";
  }
  std::cout << FormatCaptureSummary(result);
  return WriteJson(args.json, CaptureEvalToJson(result));
}

int RunWalkEval(const EvalArgs& args, const BouguetCamera& camera, const PairOptions& pair) {
  WalkEvalOptions options;
  options.list = args.list;
  options.every_frame = args.every_frame;
  options.threads = args.threads;
  options.walk.sift = pair.sift;
  if (!args.resize_given) options.walk.sift.resize_factor = WalkOptions{}.sift.resize_factor;
  options.walk.match = pair.match;
  options.walk.two_view = pair.two_view;
  options.walk.two_view.min_median_triangulation_angle_deg = args.min_parallax_deg;
  options.walk.seed = args.seed;
  options.walk.window = args.walk_window;
  options.refine = args.walk_refine;
  options.walk.match_keyframes = args.match_keyframes;
  options.gate.parallax_deg = args.parallax_deg;
  options.gate.two_view = options.walk.two_view;
  if (const std::string problem = options.Check(); !problem.empty()) {
    std::cerr << "monomesh eval: " << problem << "\n";
    return 2;
  }
  const WalkEvalResult result = EvaluateWalk(args.dataset, camera, options);
  if (!result.ok) {
    std::cerr << "monomesh eval: " << result.failure_reason << "\n";
    return 1;
  }
  if (!args.quiet) {
    for (const WalkKeyframeEval& k : result.keyframes) std::cout << FormatWalkKeyframeLine(k);
  }
  std::cout << FormatWalkSummary(result.summary);
  return WriteJson(args.json, WalkEvalToJson(result));
}

int RunEval(const EvalArgs& args) {
  if (!args.spool.empty()) return RunEntryEval(args);
  if (args.calib.empty()) {
    std::cerr << "monomesh eval: --calib is required (unless --spool is given)\n";
    return 2;
  }
  const BouguetCamera camera = LoadCalibration(args.calib);
  EvalOptions options;
  options.list = args.list;
  options.step = args.step;
  options.threads = args.threads;
  options.pair.sift.first_octave = args.first_octave;
  options.pair.sift.max_features = args.max_features;
  options.pair.match.ratio = args.ratio;
  options.pair.sift.contrast_threshold = args.contrast;
  options.pair.two_view.ransac_threshold_px = args.ransac_px;
  options.pair.two_view.bundle.huber_px = args.huber_px;
  options.pair.sift.octave_layers = args.octave_layers;
  options.pair.sift.resize_factor = args.resize;
  options.pair.two_view.seed = args.seed;
  options.pair.two_view.lo_ransac = args.lo_ransac;
  options.pair.refinement.enabled = args.refine_points;
  options.pair.sift.impl = *ParseSiftImpl(args.sift_impl);  // CLI11 checked the name.
  options.pair.mesh_mode = *ParseMeshMode(args.mesh_mode);  // CLI11 checked the name.
  options.intermediate_view = args.frame_between;
  options.views_before_a = args.frames_before_a;
  if (args.captures) return RunCaptureEval(args, camera, options.pair);
  if (args.walk) return RunWalkEval(args, camera, options.pair);
  if (const std::string problem = options.Check(); !problem.empty()) {
    std::cerr << "monomesh eval: " << problem << "\n";
    return 2;
  }
  options.mesh_figures = true;  // Issue 5: the pair's mesh rendered from A against A's depth.
  options.scale.source = *ParseScaleSource(args.scale_source);  // CLI11 checked the name.
  options.scale.camera_height_m = args.camera_height_m;
  options.scale.camera_pitch_deg = args.camera_pitch_deg;
  options.odom_noise_m = args.odom_noise_m;
  options.odom_seed = args.odom_seed;
  if (const std::string problem = options.scale.Check(); !problem.empty()) {
    std::cerr << "monomesh eval: --" << problem << "\n";
    return 2;
  }
  const EvalResult result = EvaluateTumPairs(args.dataset, camera, options);
  if (!result.ok) {
    std::cerr << "monomesh eval: " << result.failure_reason << "\n";
    return 1;
  }
  if (!args.quiet) {
    for (const PairEval& p : result.pairs) std::cout << FormatPairLine(p) << "\n";
  }
  std::cout << FormatSummary(result.summary);
  return WriteJson(args.json, EvalToJson(result));
}

}  // namespace

Runner AddEvalCommand(CLI::App& app) {
  auto* cmd = app.add_subcommand(
      "eval", "Reconstruct every pair (i, i+N) of a TUM-format folder and compare with its GT");
  auto args = std::make_shared<EvalArgs>();
  cmd->add_option("--dataset", args->dataset, "TUM-format folder (rgb.txt, groundtruth.txt)")
      ->required()
      ->check(CLI::ExistingDirectory);
  auto* calib =
      cmd->add_option("--calib", args->calib, "Calibration (TOML)")->check(CLI::ExistingFile);
  auto* spool =
      cmd->add_option("--spool", args->spool,
                      "Evaluate the daemon's spool entries (report.json) instead of reconstructing")
          ->check(CLI::ExistingDirectory);
  auto* feed_log =
      cmd->add_option(
             "--feed-log", args->feed_log,
             "With --spool: `monomesh feed --log` output mapping device timestamps to frames")
          ->check(CLI::ExistingFile);
  cmd->add_option("--list", args->list, "Image list instead of rgb.txt (e.g. keyframes_1hz.txt)");
  cmd->add_option("--step", args->step, "Pair frames i and i+N")->check(CLI::PositiveNumber);
  cmd->add_option("--json", args->json, "Write the results as JSON");
  cmd->add_option("--threads", args->threads, "OpenCV threads (default 1, as timed)");
  cmd->add_option("--first-octave", args->first_octave, "SIFT first octave (-1, 0, 1)");
  cmd->add_option("--max-features", args->max_features, "SIFT feature cap (0 = all)");
  cmd->add_option("--ratio", args->ratio, "Matching ratio test (0.8; 0.6 as in the thesis)");
  cmd->add_option("--contrast", args->contrast, "SIFT contrast threshold");
  cmd->add_option("--ransac-px", args->ransac_px, "RANSAC inlier threshold (Sampson, px)");
  cmd->add_option("--huber-px", args->huber_px, "Bundle adjustment Huber scale (px)");
  cmd->add_option("--octave-layers", args->octave_layers, "SIFT scales per octave");
  cmd->add_option("--sift-resize", args->resize, "Resize keyframes by this factor before SIFT");
  cmd->add_option("--seed", args->seed, "RANSAC seed");
  cmd->add_option("--lo-ransac", args->lo_ransac, "LO-RANSAC for F (true / false)");
  cmd->add_option("--refine-points", args->refine_points,
                  "Lucas-Kanade refinement of the points' observations in B (true / false)");
  cmd->add_option("--sift-impl", args->sift_impl, "SIFT implementation: opencv or own")
      ->check(CLI::IsMember({SiftImplName(SiftImpl::kOpenCv), SiftImplName(SiftImpl::kOwn)}));
  cmd->add_option("--mesh-mode", args->mesh_mode,
                  "The pair's mesh: dense (from the dense depth of A) or sparse (Delaunay of "
                  "the triangulated points)")
      ->check(CLI::IsMember({"dense", "sparse"}));
  cmd->add_option("--frame-between", args->frame_between,
                  "Pairs more than one frame apart: the middle frame joins the dense sweep "
                  "(true / false)");
  cmd->add_option("--frames-before-a", args->frames_before_a,
                  "Frames of the list 0.25-2 s before A, as the daemon keeps them, are offered "
                  "to the dense sweep as views behind A (true / false)");
  cmd->add_flag("--quiet", args->quiet, "Print only the summary");
  auto* captures =
      cmd->add_flag("--captures", args->captures,
                    "Play the sequence through the daemon's gate and worker and press capture");
  auto* walk = cmd->add_flag("--walk", args->walk,
                             "Run a walk (one map from many keyframes) over the sequence and "
                             "compare its keyframe poses with the ground truth");
  captures->excludes(walk)->excludes(spool);
  walk->excludes(spool);
  calib->excludes(spool);
  feed_log->needs(spool);
  cmd->add_flag("--every-frame", args->every_frame,
                "With --walk: every listed frame is a keyframe (else the gate chooses)")
      ->needs(walk);
  cmd->add_option("--walk-window", args->walk_window,
                  "With --walk: keyframes the local bundle adjustment adjusts (two fixed)")
      ->needs(walk);
  cmd->add_option("--walk-refine", args->walk_refine,
                  "With --walk: refine the map after the walk from tracks across its keyframes, "
                  "as the daemon does (true / false)")
      ->needs(walk);
  cmd->add_option("--match-keyframes", args->match_keyframes,
                  "With --walk: newest keyframes a new one is matched against")
      ->needs(walk);
  cmd->add_option("--trigger-every", args->trigger_every_s,
                  "With --captures: press capture every S seconds of video (and after each "
                  "result)")
      ->check(CLI::PositiveNumber);
  cmd->add_option("--parallax-deg", args->parallax_deg,
                  "With --captures: [keyframes] parallax_deg (the gate's target angle)");
  cmd->add_option("--min-parallax-deg", args->min_parallax_deg,
                  "[recon] min_parallax_deg (the reconstruction's minimum median angle)");
  cmd->add_option("--timeout", args->timeout_s, "With --captures: [keyframes] timeout_s");
  cmd->add_option("--tracks", args->use_tracks,
                  "With --captures: the gate's tracks join the SIFT matches (true / false)");
  cmd->add_flag("--log-gate", args->log_gate,
                "With --captures: print the gate's decision on every frame");
  cmd->add_option("--worker-latency", args->worker_latency_s,
                  "With --captures: fixed reconstruction time in video seconds (default: "
                  "measured)");
  cmd->add_option("--scale", args->scale_source,
                  "Metric scale per pair: none, odometry (simulated from the ground truth), "
                  "floor (needs --camera-height-m) or auto")
      ->check(CLI::IsMember({"none", "odometry", "floor", "auto"}));
  cmd->add_option("--odom-noise-m", args->odom_noise_m,
                  "With --scale odometry|auto: noise per position of the simulated odometry (m)")
      ->check(CLI::NonNegativeNumber);
  cmd->add_option("--odom-seed", args->odom_seed, "Seed of the simulated odometry's noise");
  cmd->add_option("--camera-height-m", args->camera_height_m,
                  "With --scale floor|auto: the camera's height above the floor (m)")
      ->check(CLI::NonNegativeNumber);
  cmd->add_option("--camera-pitch-deg", args->camera_pitch_deg,
                  "With --scale floor|auto: the camera's nominal pitch, down positive (deg)");
  // Each option of the other modes is an error, not ignored: the mode each one acts in.
  enum Mode : unsigned { kPairs = 1, kCaptures = 2, kWalk = 4, kSpool = 8 };
  const auto mode = [args] {
    return !args->spool.empty() ? kSpool : args->captures ? kCaptures : args->walk ? kWalk : kPairs;
  };
  const auto in = [mode](unsigned modes) {
    return [mode, modes] { return (mode() & modes) != 0; };
  };
  const std::string pairs = "the pair evaluation (no --spool, --captures or --walk)";
  const std::string reconstructing = "a reconstruction (--captures, --walk or the pair evaluation)";
  std::vector<OptionRule> rules;
  for (const char* name : {"--list", "--quiet", "--first-octave", "--max-features", "--ratio",
                           "--contrast", "--ransac-px", "--huber-px", "--octave-layers",
                           "--sift-resize", "--seed", "--lo-ransac", "--sift-impl"}) {
    rules.push_back({name, in(kPairs | kCaptures | kWalk), reconstructing});
  }
  for (const char* name : {"--step", "--frame-between", "--frames-before-a", "--scale"}) {
    rules.push_back({name, in(kPairs), pairs});
  }
  rules.push_back({"--threads", in(kPairs | kWalk), "--walk or " + pairs});
  for (const char* name : {"--refine-points", "--mesh-mode"}) {
    rules.push_back({name, in(kPairs | kCaptures), "--captures or " + pairs});
  }
  for (const char* name :
       {"--trigger-every", "--timeout", "--tracks", "--log-gate", "--worker-latency"}) {
    rules.push_back({name, in(kCaptures), "--captures"});
  }
  for (const char* name : {"--parallax-deg", "--min-parallax-deg"}) {
    rules.push_back({name, in(kCaptures | kWalk), "--captures or --walk"});
  }
  const auto scale_is = [args](std::vector<std::string> sources) {
    return [args, sources] {
      return std::find(sources.begin(), sources.end(), args->scale_source) != sources.end();
    };
  };
  for (const char* name : {"--odom-noise-m", "--odom-seed"}) {
    rules.push_back({name, scale_is({"odometry", "auto"}), "--scale odometry or --scale auto"});
  }
  for (const char* name : {"--camera-height-m", "--camera-pitch-deg"}) {
    rules.push_back({name, scale_is({"floor", "auto"}), "--scale floor or --scale auto"});
  }
  AddOptionRules(cmd, std::move(rules));
  return [cmd, args]() -> int {
    if (!cmd->parsed()) return -1;
    args->resize_given = cmd->count("--sift-resize") > 0;
    return RunEval(*args);
  };
}

}  // namespace mm::cli
