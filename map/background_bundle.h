#pragma once
// A bundle adjustment on a thread of its own, of a copy of the problem: ORB-SLAM's global
// bundle adjustment after a loop (Mur-Artal & Tardos 2017, sec. VIII-C), which runs while the
// map goes on growing and is merged into it afterwards (WalkMap moves what was added
// meanwhile along with it).
//
// Thread-safety: the methods from one thread; the adjustment touches only its own copy. The
// destructor waits for a running adjustment.

#include <future>

#include "map/local_bundle.h"

namespace mm {

struct BackgroundBundleResult {
  LocalBundleProblem problem;  ///< Adjusted (unchanged where the solve failed).
  LocalBundleSummary summary;
  double cpu_s = 0.0;  ///< CPU time of the adjustment's thread.
};

class BackgroundBundle {
 public:
  BackgroundBundle() = default;
  ~BackgroundBundle() = default;  // The future of std::async waits for its thread.
  BackgroundBundle(const BackgroundBundle&) = delete;
  BackgroundBundle& operator=(const BackgroundBundle&) = delete;

  /// Starts adjusting `problem`. One at a time: a running one is waited for and dropped.
  void Start(const LocalBundleOptions& options, LocalBundleProblem problem);
  /// Started and not yet taken.
  [[nodiscard]] bool running() const { return future_.valid(); }
  /// Started and finished: Take() returns at once.
  [[nodiscard]] bool done() const;
  /// Waits for the adjustment and hands its result over; running() is false after.
  BackgroundBundleResult Take();

 private:
  std::future<BackgroundBundleResult> future_;
};

}  // namespace mm
