#include "session/recent_frames.h"

#include <algorithm>
#include <cmath>

namespace mm {

std::string RecentFramesOptions::Check() const {
  if (!(spacing_s > 0)) return "spacing_s must be > 0";
  if (!(age_spacing >= 0 && age_spacing < 1)) return "age_spacing must be in [0, 1)";
  for (size_t i = 0; i < seconds_before_a.size(); ++i) {
    if (!(seconds_before_a[i] > 0) || (i > 0 && !(seconds_before_a[i] > seconds_before_a[i - 1]))) {
      return "seconds_before_a must be positive and ascending";
    }
  }
  return "";
}

RecentFrames::RecentFrames(RecentFramesOptions options) : options_(std::move(options)) {}

void RecentFrames::Add(const cv::Mat& frame, double time_s) {
  if (!Keeps(time_s)) return;
  frames_.push_back({time_s, frame});
  const double horizon_s = options_.horizon_s();
  while (!frames_.empty() && frames_.front().time_s < time_s - horizon_s) frames_.pop_front();
  // From the newest back: a frame closer to the next newer kept one than its age allows goes.
  double newer_s = time_s;
  for (size_t i = frames_.size() - 1; i-- > 0;) {
    const double gap_s =
        std::max(options_.spacing_s, options_.age_spacing * (time_s - frames_[i].time_s));
    if (newer_s - frames_[i].time_s < gap_s) {
      frames_.erase(frames_.begin() + static_cast<std::ptrdiff_t>(i));
    } else {
      newer_s = frames_[i].time_s;
    }
  }
}

std::vector<const RecentFrames::Kept*> RecentFrames::SelectBeforeA(double time_a_s) const {
  std::vector<const Kept*> out;
  const Kept* last = nullptr;
  for (const double offset : options_.seconds_before_a) {
    const double wanted = time_a_s - offset;
    const Kept* nearest = nullptr;
    for (const Kept& k : frames_) {
      if (k.time_s >= time_a_s) continue;
      if (!nearest || std::abs(k.time_s - wanted) < std::abs(nearest->time_s - wanted)) {
        nearest = &k;
      }
    }
    // Each frame once, older with each offset (the offsets ascend).
    if (nearest && std::abs(nearest->time_s - wanted) <= 0.5 * offset &&
        (!last || nearest->time_s < last->time_s)) {
      out.push_back(nearest);
      last = nearest;
    }
  }
  return out;
}

std::vector<cv::Mat> RecentFrames::BeforeA(double time_a_s) const {
  std::vector<cv::Mat> out;
  for (const Kept* k : SelectBeforeA(time_a_s)) out.push_back(k->frame);
  return out;
}

std::vector<double> RecentFrames::BeforeATimes(double time_a_s) const {
  std::vector<double> out;
  for (const Kept* k : SelectBeforeA(time_a_s)) out.push_back(k->time_s);
  return out;
}

}  // namespace mm
