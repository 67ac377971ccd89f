#pragma once
// The camera's frames of the last seconds, kept so that a capture can look behind keyframe A:
// the dense stage sweeps a view from before A beside B (recon/pipeline.h, max_views_before_a),
// which sees the part of A's image that the motion to B moves out of view (A's border when
// moving forward, the trailing side when moving sideways). Frames are kept spaced in
// proportion to their age (dense in the last fraction of a second, sparse seconds back), so a
// few cover every offset; at a trigger, the frame nearest each of `seconds_before_a` before A
// is handed out.
//
// Thread-safety: thread-bound.

#include <deque>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

namespace mm {

struct RecentFramesOptions {
  /// How long before A the handed-out frames lie (ascending): for each, the kept frame nearest
  /// it, within half of it. Spaced by factors of two, one of them lies at 1/4 to 1/2 of the
  /// time from A to B for any B taken 0.25 s to 8 s after A at a steady speed; the
  /// reconstruction poses each and takes the one nearest half of B's distance.
  std::vector<double> seconds_before_a = {0.125, 0.25, 0.5, 1.0, 2.0};
  /// Kept frames lie at least this far apart, and at least `age_spacing` times the age of the
  /// older one (the nearest kept frame to an offset o is then within about o * age_spacing / 2).
  double spacing_s = 1.0 / 16;
  double age_spacing = 0.25;
  /// How far back a kept frame may lie: 1.5 times the longest offset (the nearest to it
  /// within half of it); older frames are dropped.
  [[nodiscard]] double horizon_s() const {
    return seconds_before_a.empty() ? 0.0 : 1.5 * seconds_before_a.back();
  }
  [[nodiscard]] std::string Check() const;
};

class RecentFrames {
 public:
  explicit RecentFrames(RecentFramesOptions options = {});

  /// A frame at `time_s` (seconds, any origin, non-decreasing); kept (shared, not copied) when
  /// spacing_s has passed since the last kept one. Older frames closer together than their
  /// age allows, and those too old to be handed out, are dropped.
  void Add(const cv::Mat& frame, double time_s);
  /// Add would keep a frame at `time_s` (to skip preparing one it would not).
  [[nodiscard]] bool Keeps(double time_s) const {
    return frames_.empty() || time_s >= frames_.back().time_s + options_.spacing_s;
  }

  /// The kept frames nearest each of seconds_before_a before `time_a_s`, newest first, each
  /// at most once.
  [[nodiscard]] std::vector<cv::Mat> BeforeA(double time_a_s) const;
  /// The times of BeforeA's frames, in its order.
  [[nodiscard]] std::vector<double> BeforeATimes(double time_a_s) const;

  [[nodiscard]] size_t size() const { return frames_.size(); }

 private:
  struct Kept {
    double time_s;
    cv::Mat frame;
  };
  [[nodiscard]] std::vector<const Kept*> SelectBeforeA(double time_a_s) const;
  RecentFramesOptions options_;
  std::deque<Kept> frames_;
};

}  // namespace mm
