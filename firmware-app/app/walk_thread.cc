#include "app/walk_thread.h"

#include <malloc.h>
#include <spdlog/spdlog.h>
#include <unistd.h>

#include <ctime>

#include "app/frame_info.h"
#include "entry/walk_entry.h"
#include "map/walk_mesh.h"
#include "map/walk_refine.h"
#include "recon/features.h"
#include "recon/pipeline.h"

namespace mm {
namespace {

// The walk's scale from its map segment, in the frame of the segment's first keyframe (its
// camera A): the floor among the segment's points and its mesh's vertices (a walk sees metres
// of floor, where a pair sees a strip), and the odometry between the segment's first and last
// registered keyframes against their distance in the map.
ScaleEstimate EstimateWalkScale(const WalkMap& map, int segment, const WalkMesh& mesh,
                                const std::vector<KeyframeInfo>& infos, const DaemonConfig& config,
                                const OdometryLookup& odometry) {
  std::vector<int> members;
  for (size_t i = 0; i < map.keyframes().size(); ++i) {
    const WalkKeyframe& k = map.keyframes()[i];
    if (k.registered && k.segment == segment) members.push_back(static_cast<int>(i));
  }
  ScaleEstimate out;
  if (members.size() < 2 || static_cast<size_t>(members.back()) >= infos.size()) {
    out.why_not = "the walk's map has fewer than two registered keyframes";
    return out;
  }
  const auto centre = [&](int k) {
    const Eigen::Isometry3d& cam_from_segment =
        map.keyframes()[static_cast<size_t>(k)].cam_from_segment;
    return Eigen::Vector3d(-cam_from_segment.linear().transpose() * cam_from_segment.translation());
  };
  std::vector<Eigen::Vector3d> points;
  for (const WalkPoint& p : map.points()) {
    if (p.valid && p.segment == segment) points.push_back(p.position_in_segment);
  }
  for (const WalkMeshPart& part : mesh.parts) {
    for (const Eigen::Vector3f& v : part.mesh.vertices) points.push_back(v.cast<double>());
  }
  PairScaleInputs odometry_at;
  if (odometry && (config.scale.source == ScaleSource::kOdometry ||
                   config.scale.source == ScaleSource::kAuto)) {
    odometry_at = odometry(infos[static_cast<size_t>(members.front())],
                           infos[static_cast<size_t>(members.back())]);
  }
  ScaleInputs inputs;  // No image: the walk's walls fix the floor's normal.
  inputs.odometry_a_m = odometry_at.odometry_a_m;
  inputs.odometry_b_m = odometry_at.odometry_b_m;
  inputs.odometry_why_not = odometry_at.odometry_why_not;
  inputs.baseline_units = (centre(members.back()) - centre(members.front())).norm();
  inputs.points_in_a = points;
  return EstimateScale(inputs, config.scale);
}

}  // namespace

namespace {

double SecondsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

}  // namespace

WalkThread::WalkThread(const DaemonConfig& config, const Undistorter& undistorter, Spool* spool,
                       int done_fd, OdometryLookup odometry)
    : config_(config),
      undistorter_(undistorter),
      spool_(spool),
      done_fd_(done_fd),
      odometry_(std::move(odometry)) {
  thread_ = std::thread([this] { RunGuarded(); });
}

WalkThread::~WalkThread() {
  {
    std::lock_guard lock(mutex_);
    quit_ = true;
  }
  cv_.notify_all();
  thread_.join();
}

void WalkThread::Signal() const {
  const uint64_t one = 1;
  [[maybe_unused]] const ssize_t n = ::write(done_fd_, &one, sizeof(one));
}

void WalkThread::Start(uint64_t walk, FramePtr first) {
  std::lock_guard lock(mutex_);
  tracker_ = std::make_unique<WalkTracker>(
      undistorter_.output_camera().K(),
      WalkTrackerOptions{.walk = config_.walk.map, .gate = config_.walk.gate});
  jpegs_.clear();
  infos_.clear();
  summaries_.clear();
  started_ = std::chrono::steady_clock::now();
  status_ = WalkStatus{.walking = true, .walk = walk};
  stop_.reset();
  posted_ = std::move(first);
  cv_.notify_all();
}

bool WalkThread::Offer(FramePtr frame) {
  std::lock_guard lock(mutex_);
  if (!status_.walking || stop_ || running_ || posted_) return false;
  posted_ = std::move(frame);
  cv_.notify_all();
  return true;
}

void WalkThread::Stop(const std::string& reason) {
  std::lock_guard lock(mutex_);
  if (!status_.walking || stop_) return;
  stop_ = reason;
  status_.finishing = true;
  cv_.notify_all();
}

void WalkThread::WaitFinished() {
  std::unique_lock lock(mutex_);
  cv_.wait(lock, [&] { return !status_.walking || fatal_error_.has_value(); });
}

WalkStatus WalkThread::status() const {
  std::lock_guard lock(mutex_);
  WalkStatus s = status_;
  if (s.walking) s.seconds = SecondsSince(started_);
  return s;
}

std::vector<WalkKeyframeSummary> WalkThread::TakeKeyframes() {
  std::lock_guard lock(mutex_);
  return std::exchange(added_, {});
}

std::optional<WalkOutcome> WalkThread::TakeOutcome() {
  std::lock_guard lock(mutex_);
  if (outcomes_.empty()) return std::nullopt;
  WalkOutcome o = std::move(outcomes_.front());
  outcomes_.pop_front();
  return o;
}

std::optional<std::string> WalkThread::fatal_error() const {
  std::lock_guard lock(mutex_);
  return fatal_error_;
}

// An exception leaving a std::thread calls std::terminate: it is kept for the loop instead.
void WalkThread::RunGuarded() {
  std::string fatal;
  try {
    Run();
    return;
  } catch (const std::exception& e) {
    fatal = std::string("walk: ") + e.what();
  } catch (...) {
    fatal = "walk: unknown exception";
  }
  {
    std::lock_guard lock(mutex_);
    fatal_error_ = std::move(fatal);
  }
  cv_.notify_all();
  Signal();
}

void WalkThread::Run() {
  for (;;) {
    FramePtr frame;
    {
      std::unique_lock lock(mutex_);
      cv_.wait(lock, [&] { return quit_ || posted_ || stop_; });
      if (quit_) return;
      if (posted_) {
        frame = std::move(posted_);
        posted_.reset();
        running_ = true;
      }
    }
    if (frame) {
      AddFrame(frame);
      bool limit = false;
      {
        std::lock_guard lock(mutex_);
        running_ = false;
        limit = status_.keyframes >= config_.walk.max_keyframes && !stop_;
        if (limit) {
          stop_ = "keyframe limit";
          status_.finishing = true;
        }
      }
      Signal();
      continue;
    }
    WalkOutcome outcome = Finish();
    {
      std::lock_guard lock(mutex_);
      outcomes_.push_back(std::move(outcome));
      status_.walking = false;
      status_.finishing = false;
      stop_.reset();
      tracker_.reset();
      jpegs_ = {};
      infos_ = {};
      summaries_ = {};
    }
    cv_.notify_all();
    Signal();
  }
}

void WalkThread::AddFrame(const FramePtr& frame) {
  cv::Mat undistorted;
  try {
    undistorted = undistorter_.Apply(frame->image);
  } catch (const std::exception& e) {
    // A frame that does not fit the calibration: skipped (logged), the walk goes on.
    spdlog::error("walk: frame {} ({}) skipped: {}", frame->sequence, frame->source_id, e.what());
    return;
  }
  const WalkFrameStep step = tracker_->AddFrame(ToGray(undistorted), frame->source_time_s);
  // The loop's background bundle adjustment has been applied and its copy of the segment
  // freed: glibc keeps the freed pages of its thread's arena resident until trimmed, and the
  // walk's later peaks (the map mesh) would add to them (measured: 639 MB peak over the
  // 300-keyframe walk without this, against 434-457 MB before the adjustment ran there).
  if (step.added && step.added->global_bundle_applied) malloc_trim(0);
  std::lock_guard lock(mutex_);
  ++status_.frames;
  status_.parallax_deg = tracker_->parallax_deg();
  status_.tracking = step.tracked;
  if (step.tracked) ++status_.tracked_frames;
  if (!step.added) return;
  const WalkMap& map = tracker_->map();
  status_.segments = map.segments();
  status_.relocalizations = map.relocalizations();
  status_.merges = map.merges();
  status_.loop_closures = map.loop_closures();
  status_.lost_keyframes = map.lost_keyframes();
  jpegs_.push_back(EncodeKeyframeJpeg(undistorted));
  infos_.push_back(KeyframeInfoOf(*frame));
  summaries_.push_back(*step.added);
  ++status_.keyframes;
  if (step.added->registered && step.added->failure.empty()) ++status_.registered;
  status_.segment = step.added->segment;
  status_.parallax_deg = 0.0;  // The new keyframe is the reference now.
  added_.push_back(*step.added);
}

WalkOutcome WalkThread::Finish() {
  const auto start = std::chrono::steady_clock::now();
  WalkOutcome out;
  std::string reason;
  {
    std::lock_guard lock(mutex_);
    out.walk = status_.walk;
    reason = stop_.value_or("operator");
  }
  out.stop_reason = reason;
  tracker_->Finish();
  const WalkMap& map = tracker_->map();
  out.keyframes = static_cast<int>(map.keyframes().size());
  out.segments = map.segments();
  try {
    const int segment = LargestSegment(map);
    const BouguetCamera& camera = undistorter_.output_camera();
    const KeyframeImageFn keyframe_image = [&](int k) {
      return DecodeKeyframeJpeg(jpegs_[static_cast<size_t>(k)]);
    };
    TrackRefineSummary refinement;
    const auto refine_start = std::chrono::steady_clock::now();
    if (config_.walk.refine && segment >= 0) {
      refinement = RefineSegment(&tracker_->mutable_map(), segment, camera.K(), keyframe_image,
                                 TrackRefineOptions{});
      if (refinement.ran) {
        spdlog::info(
            "walk: refined: {} of {} pairs of keyframes verified, {} points, RMS {:.3f} px, "
            "{:.2f} s CPU",
            refinement.verified_pairs, refinement.pairs, refinement.points,
            refinement.bundle.final_rms_px, refinement.cpu_s);
      } else {
        spdlog::info("walk: not refined: {}", refinement.skipped.empty()
                                                  ? "its adjustment did not run"
                                                  : refinement.skipped);
      }
    }
    const double refinement_seconds = SecondsSince(refine_start);
    // The walk's SIFT is done: its pyramid workspace goes before the mesh and the preview
    // allocate theirs (the peak of a long walk), and so do the pages the refinement's
    // adjustment freed (glibc keeps them resident otherwise, as after a loop's).
    ReleaseSiftWorkspace();
    if (refinement.ran) malloc_trim(0);
    WalkMeshOptions mesh_options;
    mesh_options.dense = config_.walk.dense_mesh;
    mesh_options.max_parts = config_.walk.max_mesh_parts;
    mesh_options.dense_mesh = config_.recon.dense_mesh;
    const WalkMesh mesh = BuildWalkMesh(map, segment, camera.K(), keyframe_image, mesh_options);
    ScaleEstimate metric;
    if (config_.scale.source != ScaleSource::kNone) {
      metric = EstimateWalkScale(map, segment, mesh, infos_, config_, odometry_);
      if (metric.scaled()) {
        spdlog::info("walk: {:.4f} m per unit from {}", metric.metres_per_unit,
                     ScaleSourceName(metric.source));
      } else {
        spdlog::info("walk: unscaled: {}", metric.why_not);
      }
    }
    WalkReport report;
    const EncodedEntry entry =
        EncodeWalkEntry(WalkEntryInput{.map = &map,
                                       .mesh = &mesh,
                                       .keyframe_jpegs = jpegs_,
                                       .keyframe_infos = infos_,
                                       .summaries = summaries_,
                                       .camera = camera,
                                       .scale = metric,
                                       .stop_reason = reason,
                                       .frames = status().frames,
                                       .walk_seconds = SecondsSince(started_),
                                       .refinement = refinement,
                                       .refinement_seconds = refinement_seconds},
                        start, &report);
    out.registered = report.counts.registered;
    const SpoolCommit commit = spool_->Commit(entry.files, std::time(nullptr));
    if (commit.ok) {
      out.ok = true;
      out.entry = commit.entry.string();
      if (!commit.error.empty()) spdlog::warn("spool: {}", commit.error);
    } else {
      out.error = "spool write failed: " + commit.error;
    }
  } catch (const std::exception& e) {
    out.error = std::string("internal error: ") + e.what();
  }
  out.seconds = SecondsSince(start);
  return out;
}

}  // namespace mm
