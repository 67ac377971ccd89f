#pragma once
// The reconstruction worker (docs/architecture.md, threads): one job at a time, a queue of one.
// A job is a capture's keyframes A and B with the gate's tracks; the worker runs RunPairJob
// (the reconstruction and the entry's files), commits the entry to the spool (retention
// included) and hands the outcome to the event loop through `done_fd`. While the gate waits
// for B, Prepare computes keyframe A's SIFT and the views before A.
//
// Thread-safety: the public methods from the event loop; the job runs on the worker's thread.

#include <condition_variable>
#include <cstdint>
#include <deque>
#include <mutex>
#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "app/config.h"
#include "app/pair_job.h"
#include "app/shared_odometry.h"
#include "calib/camera_model.h"
#include "capture/frame.h"
#include "recon/pipeline.h"
#include "session/capture_session.h"
#include "spool/spool.h"

namespace mm {

struct Job {
  uint64_t capture_id = 0;
  FramePtr a;  // Raw frames, for the report.
  FramePtr b;
  cv::Mat undistorted_a;  // What the reconstruction sees.
  cv::Mat undistorted_b;
  std::vector<TrackCorrespondence> tracks;  // The gate's tracks from A to B.
  std::vector<SourceView> between;          // A frame about halfway, with the tracks at it.
  std::vector<KeyframeBTry> tries;          // This capture's B tries so far (the last is this B).
};

struct JobOutcome {
  uint64_t capture_id = 0;
  bool ok = false;
  std::string entry;
  std::string error;
  /// The reconstruction refused the pair (as opposed to a spool or internal error): the
  /// session decides whether a later B may follow.
  bool refused = false;
  TwoViewFailure failure = TwoViewFailure::kNone;
  std::string refusal;  // The reconstruction's reason.
  double seconds = 0.0;
};

// The reconstruction worker: a thread with a queue of at most one job.
class Worker {
 public:
  Worker(const DaemonConfig& config, const BouguetCamera& undistorted_camera, Spool* spool,
         SharedOdometry* odometry, int done_fd);
  ~Worker() { Finish(); }
  Worker(const Worker&) = delete;
  Worker& operator=(const Worker&) = delete;

  /// Starts keyframe A's SIFT and the tracking of A's corners back through the frames before
  /// A (undistorted gray, newest first: source views before A for the dense stage) while the
  /// gate waits for B (the worker is idle then). A later Submit for the same capture uses the
  /// results.
  void Prepare(uint64_t capture_id, cv::Mat undistorted_a, std::vector<cv::Mat> frames_before_a);

  /// Stops the thread after the job queued or running (a capture accepted is a capture
  /// finished: its outcome stays for TakeOutcome); a pending Prepare is dropped.
  void Finish();

  /// Returns once the worker has loaded the preview's GL driver (or failed to, or died).
  void WaitUntilWarmedUp();

  /// False when a job is already queued or running.
  bool Submit(Job job);

  /// Set when an exception reached the thread's top (the thread has ended): the daemon exits 70.
  std::optional<std::string> fatal_error();

  std::optional<JobOutcome> TakeOutcome();

 private:
  // An exception leaving a std::thread calls std::terminate (SIGABRT, restarted forever by
  // systemd): it is caught here, kept for the loop and reported through the done eventfd.
  void RunGuarded();

  void MarkWarmedUp();

  void Run();

  JobOutcome Process(const Job& job);

  // The appliance's memory policy on the configured options: the SIFT pyramid (about 100 MB
  // at 640x480) is freed once B's features are out, so it is not held through the dense
  // stage and the rendering (peak RSS at 640x480: 296 -> 199 MiB); A's SIFT of the next
  // capture, computed while the gate waits for B, allocates it again.
  static PairOptions AppliancePairOptions(PairOptions options);

  const DaemonConfig& config_;
  const PairOptions recon_options_;
  BouguetCamera camera_;  // Of the undistorted frames.
  Spool* spool_;
  SharedOdometry* odometry_;
  int done_fd_;
  std::thread thread_;
  std::mutex mutex_;
  std::condition_variable cv_;
  bool stop_ = false;       // Guarded by mutex_.
  bool busy_ = false;       // Guarded by mutex_.
  bool warmed_up_ = false;  // Guarded by mutex_: the GL driver is loaded (or failed to).
  struct PrepareJob {
    uint64_t capture_id = 0;
    cv::Mat image;
    std::vector<cv::Mat> frames_before_a;
  };
  std::optional<Job> job_;                  // Guarded by mutex_.
  std::optional<PrepareJob> prepare_;       // Guarded by mutex_.
  Features features_;                       // Keyframe A's, guarded by mutex_.
  std::vector<SourceView> views_before_a_;  // Keyframe A's, guarded by mutex_.
  uint64_t features_capture_ = 0;           // Whose features_ are; guarded by mutex_.
  std::deque<JobOutcome> outcomes_;         // Guarded by mutex_.
  std::optional<std::string> fatal_error_;  // Guarded by mutex_.
};

}  // namespace mm
