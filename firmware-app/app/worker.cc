#include "app/worker.h"

#include <spdlog/spdlog.h>

#include <chrono>
#include <ctime>
#include <exception>

#include "app/event_fd.h"
#include "app/frame_info.h"
#include "entry/entry.h"
#include "render/renderer.h"

namespace mm {

Worker::Worker(const DaemonConfig& config, const BouguetCamera& undistorted_camera, Spool* spool,
               SharedOdometry* odometry, int done_fd)
    : config_(config),
      recon_options_(AppliancePairOptions(config.recon)),
      camera_(undistorted_camera),
      spool_(spool),
      odometry_(odometry),
      done_fd_(done_fd) {
  thread_ = std::thread([this] { RunGuarded(); });
}

void Worker::Prepare(uint64_t capture_id, cv::Mat undistorted_a,
                     std::vector<cv::Mat> frames_before_a) {
  std::lock_guard lock(mutex_);
  prepare_ = PrepareJob{capture_id, std::move(undistorted_a), std::move(frames_before_a)};
  cv_.notify_all();
}

void Worker::Finish() {
  {
    std::lock_guard lock(mutex_);
    stop_ = true;
  }
  cv_.notify_all();
  if (thread_.joinable()) thread_.join();
}

void Worker::WaitUntilWarmedUp() {
  std::unique_lock lock(mutex_);
  cv_.wait(lock, [&] { return warmed_up_; });
}

bool Worker::Submit(Job job) {
  std::lock_guard lock(mutex_);
  if (job_ || busy_) return false;
  job_ = std::move(job);
  cv_.notify_all();
  return true;
}

std::optional<std::string> Worker::fatal_error() {
  std::lock_guard lock(mutex_);
  return fatal_error_;
}

std::optional<JobOutcome> Worker::TakeOutcome() {
  std::lock_guard lock(mutex_);
  if (outcomes_.empty()) return std::nullopt;
  JobOutcome o = std::move(outcomes_.front());
  outcomes_.pop_front();
  return o;
}

void Worker::RunGuarded() {
  std::string fatal;
  try {
    Run();
    return;
  } catch (const std::exception& e) {
    fatal = std::string("worker: ") + e.what();
  } catch (...) {
    fatal = "worker: unknown exception";
  }
  {
    std::lock_guard lock(mutex_);
    fatal_error_ = std::move(fatal);
  }
  MarkWarmedUp();
  SignalEventFd(done_fd_);
}

void Worker::MarkWarmedUp() {
  {
    std::lock_guard lock(mutex_);
    warmed_up_ = true;
  }
  cv_.notify_all();
}

void Worker::Run() {
  // The preview's GL driver is loaded on this thread, so its allocations stay in the
  // worker's malloc arena (on the main thread they raised the peak RSS by about 5 MB).
  if (const std::string error = WarmUpRenderer(); !error.empty()) {
    spdlog::warn("preview renderer unavailable (entries get no preview.png): {}", error);
  }
  MarkWarmedUp();
  for (;;) {
    Job job;
    {
      std::unique_lock lock(mutex_);
      cv_.wait(lock, [&] { return stop_ || job_.has_value() || prepare_.has_value(); });
      if (stop_ && !job_.has_value()) return;
      if (prepare_.has_value() && !stop_) {
        PrepareJob prepare = std::move(*prepare_);
        prepare_.reset();
        lock.unlock();
        Features features;
        std::vector<SourceView> views_before_a;
        try {
          features = ExtractKeyframeFeatures(prepare.image, recon_options_);
          if (recon_options_.mesh_mode == MeshMode::kDense) {
            views_before_a =
                ViewsBeforeA(ToGray(prepare.image), prepare.frames_before_a, config_.gate);
          }
        } catch (const std::exception& e) {
          // Not fatal: Process extracts A's features again and reports its own failure.
          spdlog::error("capture {}: keyframe A features: {}", prepare.capture_id, e.what());
          lock.lock();
          continue;
        }
        lock.lock();
        features_ = std::move(features);
        views_before_a_ = std::move(views_before_a);
        features_capture_ = prepare.capture_id;
        continue;
      }
      job = std::move(*job_);
      job_.reset();
      busy_ = true;
    }
    JobOutcome outcome = Process(job);
    {
      std::lock_guard lock(mutex_);
      busy_ = false;
      outcomes_.push_back(std::move(outcome));
    }
    SignalEventFd(done_fd_);
  }
}

JobOutcome Worker::Process(const Job& job) {
  const auto start = std::chrono::steady_clock::now();
  JobOutcome outcome;
  outcome.capture_id = job.capture_id;
  try {
    Features features_a;
    bool have_features = false;
    std::vector<SourceView> views = job.between;
    {
      std::lock_guard lock(mutex_);
      // Copied, not moved: a refused B may be followed by a later one from the same A.
      if (features_capture_ == job.capture_id) {
        features_a = features_;
        have_features = true;
        views.insert(views.end(), views_before_a_.begin(), views_before_a_.end());
      }
    }
    const KeyframeInfo a = KeyframeInfoOf(*job.a), b = KeyframeInfoOf(*job.b);
    PairScaleInputs scale;
    if (config_.scale.source == ScaleSource::kOdometry ||
        config_.scale.source == ScaleSource::kAuto) {
      scale = odometry_->Lookup(config_, a, b);
    }
    scale.options = config_.scale;
    PairJobResult result =
        RunPairJob(job.undistorted_a, job.undistorted_b, a, b, camera_, recon_options_,
                   have_features ? &features_a : nullptr, job.tracks, views, job.tries, scale);
    if (!result.ok) {
      outcome.error = "reconstruction failed: " + result.error;
      outcome.refused = true;
      outcome.failure = result.recon.geometry.failure;
      outcome.refusal = result.error;
    } else {
      const SpoolCommit commit = WriteEntry(*spool_, result.entry, std::time(nullptr));
      if (commit.ok) {
        outcome.ok = true;
        outcome.entry = commit.entry.string();
        if (!commit.error.empty()) spdlog::warn("spool: {}", commit.error);
        if (commit.removed_by_retention > 0) {
          spdlog::info("spool: retention removed {} old entries", commit.removed_by_retention);
        }
      } else {
        outcome.error = "spool write failed: " + commit.error;
      }
    }
  } catch (const std::exception& e) {
    outcome.error = std::string("internal error: ") + e.what();
  }
  outcome.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return outcome;
}

PairOptions Worker::AppliancePairOptions(PairOptions options) {
  options.release_sift_workspace_after_b = true;
  return options;
}

}  // namespace mm
