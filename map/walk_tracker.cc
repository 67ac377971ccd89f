#include "map/walk_tracker.h"

namespace mm {

std::string WalkTrackerOptions::Check() const {
  if (std::string p = walk.Check(); !p.empty()) return "walk." + p;
  if (std::string p = gate.Check(); !p.empty()) return "gate." + p;
  return {};
}

WalkTracker::WalkTracker(const Eigen::Matrix3d& K, const WalkTrackerOptions& options)
    : map_(K, options.walk), gate_(K, options.gate) {}

WalkFrameStep WalkTracker::AddFrame(const cv::Mat& gray, double timestamp_s) {
  WalkFrameStep step;
  if (started_) {
    step.decision = gate_.Update(gray);
    last_decision_ = step.decision;
    if (step.decision.verdict == GateDecision::Verdict::kWait) return step;
  }
  started_ = true;
  step.added = map_.AddKeyframe(gray, timestamp_s);
  gate_.Start(gray);
  return step;
}

}  // namespace mm
