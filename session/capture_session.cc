#include "session/capture_session.h"

#include <algorithm>
#include <map>

namespace mm {
namespace {

// The gate's tracks as correspondences: where each started in A and where it is in a frame.
std::vector<TrackCorrespondence> Correspondences(const std::vector<cv::Point2f>& origins_a,
                                                 const std::vector<cv::Point2f>& positions) {
  std::vector<TrackCorrespondence> out;
  out.reserve(origins_a.size());
  for (size_t i = 0; i < origins_a.size() && i < positions.size(); ++i) {
    out.push_back({Eigen::Vector2d(origins_a[i].x, origins_a[i].y),
                   Eigen::Vector2d(positions[i].x, positions[i].y)});
  }
  return out;
}

}  // namespace

SourceView SourceViewOf(const GateWaypoint& waypoint) {
  return {waypoint.gray, Correspondences(waypoint.origins_a, waypoint.positions)};
}

std::vector<SourceView> ViewsBeforeA(const cv::Mat& gray_a,
                                     std::span<const cv::Mat> frames_before_a,
                                     const KeyframeGateOptions& options) {
  std::vector<SourceView> out;
  for (const GateWaypoint& w : TrackBackFromA(gray_a, frames_before_a, options)) {
    out.push_back(SourceViewOf(w));
  }
  return out;
}

const char* CaptureEndName(CaptureEnd end) {
  switch (end) {
    case CaptureEnd::kOpen:
      return "open";
    case CaptureEnd::kAccepted:
      return "accepted";
    case CaptureEnd::kRefused:
      return "refused";
    case CaptureEnd::kLostTrack:
      return "lost_track";
    case CaptureEnd::kTimeout:
      return "not_enough_motion";
    case CaptureEnd::kTooManyTries:
      return "too_many_tries";
    case CaptureEnd::kAborted:
      return "aborted";
  }
  return "?";
}

std::string CaptureSessionOptions::Check() const {
  if (!(timeout_s > 0)) return "timeout_s: must be > 0";
  if (!(retry_parallax_growth >= 1)) return "retry_parallax_growth: must be >= 1";
  if (max_tries < 1) return "max_tries: must be >= 1";
  return gate.Check();
}

CaptureSession::CaptureSession(const Eigen::Matrix3d& K, CaptureSessionOptions options)
    : options_(options), gate_(K, options_.gate) {}

int CaptureSession::Start(const cv::Mat& gray_a, double time_s) {
  open_ = true;
  end_ = CaptureEnd::kOpen;
  in_flight_ = false;
  lost_ = false;
  lost_reason_.clear();
  start_time_s_ = time_s;
  tries_.clear();
  failure_reason_.clear();
  const int corners = gate_.Start(gray_a);
  last_decision_ = GateDecision{};
  last_decision_.tracks = corners;
  last_decision_.reason = "no frame after A reached the gate";
  return corners;
}

CaptureSession::Step CaptureSession::Fail(CaptureEnd end, std::string reason) {
  open_ = false;
  end_ = end;
  in_flight_ = false;
  failure_reason_ = std::move(reason);
  return Step::kFailed;
}

std::string CaptureSession::RefusalSummary() const {
  std::map<std::string, int> counts;
  int refused = 0;
  for (const KeyframeBTry& t : tries_) {
    if (t.accepted) continue;
    ++refused;
    ++counts[TwoViewFailureName(t.failure)];
  }
  if (refused == 0) return "no B tried";
  std::string out = std::to_string(refused) + " B refused:";
  for (const auto& [name, n] : counts) out += " " + name + " x" + std::to_string(n);
  return out;
}

CaptureSession::Step CaptureSession::OnFrame(const cv::Mat& gray, uint64_t sequence, double time_s,
                                             bool can_submit) {
  if (!wants_frames()) return Step::kWait;
  return OnTracked(Track(gray), sequence, time_s, can_submit);
}

GateDecision CaptureSession::Track(const cv::Mat& gray) { return gate_.Update(gray); }

CaptureSession::Step CaptureSession::OnTracked(const GateDecision& decision, uint64_t sequence,
                                               double time_s, bool can_submit) {
  if (!wants_frames()) return Step::kWait;  // Ended, or waiting for the last B's result only.
  last_decision_ = decision;
  if (last_decision_.verdict == GateDecision::Verdict::kLostTrack) {
    lost_ = true;
    lost_reason_ = last_decision_.reason;
    if (in_flight_) return Step::kWait;
    // The tracks broke between two frames (a jump the KLT pyramid cannot follow: dropped
    // frames under load, a fast swing), which says nothing about the pair A-this frame. The
    // reconstruction matches descriptors, not tracks: hand it this frame as a last B, and end
    // the capture as lost only if it refuses.
    if (options_.b_after_lost_track && can_submit &&
        static_cast<int>(tries_.size()) < options_.max_tries) {
      return SubmitB(sequence, time_s, /*after_lost_track=*/true);
    }
    return Fail(CaptureEnd::kLostTrack, LostTrackReason());
  }
  if (in_flight_) return Step::kWait;
  if (const Step s = OnTime(time_s); s == Step::kFailed) return s;
  if (last_decision_.verdict != GateDecision::Verdict::kTakeB || !can_submit) return Step::kWait;
  return SubmitB(sequence, time_s, /*after_lost_track=*/false);
}

CaptureSession::Step CaptureSession::SubmitB(uint64_t sequence, double time_s,
                                             bool after_lost_track) {
  KeyframeBTry attempt;
  attempt.frame_sequence = sequence;
  attempt.seconds_after_a = time_s - start_time_s_;
  attempt.gate_parallax_deg = after_lost_track ? 0.0 : last_decision_.median_parallax_deg;
  attempt.tracks = last_decision_.tracks;
  attempt.after_lost_track = after_lost_track;
  tries_.push_back(attempt);
  in_flight_ = true;
  return Step::kSubmitB;
}

std::string CaptureSession::LostTrackReason() const {
  const bool refused = std::any_of(tries_.begin(), tries_.end(),
                                   [](const KeyframeBTry& t) { return !t.accepted; });
  return refused ? lost_reason_ + " after " + RefusalSummary() : lost_reason_;
}

CaptureSession::Step CaptureSession::OnResult(bool accepted, TwoViewFailure failure,
                                              const std::string& reason) {
  if (!open_ || !in_flight_ || tries_.empty()) return Step::kWait;
  in_flight_ = false;
  KeyframeBTry& last = tries_.back();
  last.accepted = accepted;
  last.failure = failure;
  last.reason = accepted ? std::string() : reason;
  if (accepted) {
    open_ = false;
    end_ = CaptureEnd::kAccepted;
    return Step::kDone;
  }
  if (lost_) return Fail(CaptureEnd::kLostTrack, LostTrackReason() + " (last: " + reason + ")");
  if (!MoreMotionMayCure(failure)) return Fail(CaptureEnd::kRefused, reason);
  if (static_cast<int>(tries_.size()) >= options_.max_tries) {
    return Fail(CaptureEnd::kTooManyTries,
                "no accepted keyframe B after " + RefusalSummary() + " (last: " + reason + ")");
  }
  // More motion from the same A: the next B must see clearly more parallax than this one.
  gate_.RequireParallax(last.gate_parallax_deg * options_.retry_parallax_growth);
  return Step::kWait;
}

CaptureSession::Step CaptureSession::OnTime(double time_s) {
  if (!open_ || in_flight_) return Step::kWait;
  if (time_s - start_time_s_ <= options_.timeout_s) return Step::kWait;
  std::string reason =
      "not enough motion: no keyframe B within " + std::to_string(options_.timeout_s) +
      " s (last frame: " + std::to_string(last_decision_.tracks) + " tracks, parallax " +
      std::to_string(last_decision_.median_parallax_deg) + " deg of " +
      std::to_string(gate_.required_parallax_deg()) + "; " + last_decision_.reason + ")";
  if (!tries_.empty()) reason += "; " + RefusalSummary();
  return Fail(CaptureEnd::kTimeout, std::move(reason));
}

std::vector<SourceView> CaptureSession::Between() const {
  const GateWaypoint& frame = gate_.halfway();
  if (frame.gray.empty()) return {};
  return {SourceViewOf(frame)};
}

std::vector<TrackCorrespondence> CaptureSession::Tracks() const {
  return Correspondences(gate_.track_origins_a(), gate_.track_positions());
}

}  // namespace mm
