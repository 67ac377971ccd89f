// The capture's state machine on the event loop, from a press to an entry (docs/architecture.md,
// daemon states): a trigger takes keyframe A and starts the session; the gate thread's frames
// are applied (ApplyGate) until keyframe B goes to the worker; the worker's result ends the
// capture with an entry or a failure, or (a refusal more motion can cure) tracks on for a
// later B. idle -> tracking -> reconstructing -> idle.

#include "app/daemon_loop.h"

#include <spdlog/spdlog.h>

#include <chrono>
#include <exception>
#include <utility>

#include "recon/pipeline.h"

namespace mm::daemon_detail {

void Daemon::OnTrigger(const char* origin, json* reply) {
  // Every refusal is answered, logged and emitted.
  const auto refuse = [&](const std::string& error) {
    *reply = {{"ok", false}, {"error", error}};
    Emit({{"event", "trigger_refused"}, {"origin", origin}, {"error", error}});
  };
  if (state_ != State::kIdle) {
    refuse(std::string("busy: ") + Name(state_));
    spdlog::warn("trigger ({}) refused: busy {}", origin, Name(state_));
    return;
  }
  // A frame of an ended capture may still be in the gate: finished first, its result dropped.
  gate_->WaitIdle();
  (void)gate_->Take();
  FramePtr latest = capture_->Latest();
  if (!latest) {
    refuse("no frame from the camera yet");
    spdlog::warn("trigger ({}) refused: no frame yet", origin);
    return;
  }
  cv::Mat undistorted;
  try {
    undistorted = undistorter_.Apply(latest->image);
  } catch (const std::exception& e) {
    refuse(std::string("frame does not fit the calibration: ") + e.what());
    spdlog::error("trigger ({}) refused: {}", origin, e.what());
    return;
  }
  ++captures_;
  last_trigger_ = origin;
  keyframe_a_ = std::move(latest);
  undistorted_a_ = undistorted;
  last_tracked_sequence_ = keyframe_a_->sequence;
  const int corners = session_.Start(ToGray(undistorted_a_), NowSeconds());
  // The frames kept from before A, undistorted as A (the worker tracks A's corners back).
  std::vector<cv::Mat> frames_before_a;
  for (const cv::Mat& gray : recent_frames_.BeforeA(FrameTimeSeconds(*keyframe_a_))) {
    try {
      frames_before_a.push_back(undistorter_.Apply(gray));
    } catch (const std::exception& e) {
      spdlog::warn("capture {}: a frame before A does not fit the calibration: {}", captures_,
                   e.what());
    }
  }
  worker_->Prepare(captures_, undistorted_a_, std::move(frames_before_a));
  spdlog::info("capture {} ({}): keyframe A = frame {} ({}), {} corners to track", captures_,
               origin, keyframe_a_->sequence, keyframe_a_->source_id, corners);
  Emit({{"event", "keyframe_a"},
        {"capture", captures_},
        {"origin", origin},
        {"frame", keyframe_a_->sequence},
        {"source", keyframe_a_->source_id},
        {"corners", corners}});
  SetState(State::kTracking);
  *reply = {{"ok", true}, {"capture", captures_}};
}

// The GPIO button with [trigger] long_press_ms: a press held that long starts or stops a walk, a
// shorter one is a capture (both at the release). Otherwise a press is a capture at once.
void Daemon::OnTriggerEvent(Trigger* trigger, const TriggerEvent& event) {
  const bool gestures = config_.long_press_ms > 0 && dynamic_cast<GpioButton*>(trigger) != nullptr;
  if (!gestures) {
    if (event.pressed) {
      json reply;
      OnTrigger(event.source.c_str(), &reply);
    }
    return;
  }
  if (event.pressed) {
    press_time_ns_ = event.time_ns;
    return;
  }
  if (!press_time_ns_) return;  // A release without its press (held at the start).
  const int64_t held_ns = event.time_ns - *press_time_ns_;
  press_time_ns_.reset();
  if (held_ns >= int64_t{config_.long_press_ms} * 1'000'000) {
    const std::string origin = event.source + " (long press)";
    const json reply = state_ == State::kWalking ? OnWalkStop(origin.c_str(), "operator")
                                                 : OnWalkStart(origin.c_str());
    if (!reply.value("ok", false)) {
      spdlog::warn("{}: {}", origin, reply.value("error", std::string()));
    }
    return;
  }
  json reply;
  OnTrigger(event.source.c_str(), &reply);
}

double Daemon::NowSeconds() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

void Daemon::EndCapture(const std::string& error) {
  spdlog::error("capture {}: {}", captures_, error);
  Emit({{"event", "capture_failed"}, {"capture", captures_}, {"error", error}});
  LogHookStart(hooks_.OnFailure(error, captures_));
  session_.Abort(error);
  last_result_ = {{"capture", captures_},
                  {"ok", false},
                  {"error", error},
                  {"b_tries", session_.tries().size()}};
  keyframe_a_.reset();
  undistorted_a_.release();
  SetState(State::kIdle);
}

void Daemon::OnFrame() {
  if (state_ == State::kWalking) {
    // The walk thread takes the newest frame when it is free (the others are skipped).
    FramePtr frame = capture_->Latest();
    if (frame && frame->sequence > last_walk_sequence_ && walk_->Offer(frame)) {
      last_walk_sequence_ = frame->sequence;
    }
    return;
  }
  KeepRecentFrame();
  // Frames feed the session while a capture is open, also while a B is being reconstructed
  // (the tracks stay alive for a later B if that one is refused). The gate thread tracks A's
  // corners into the newest frame when it is free (frames that arrive meanwhile are skipped;
  // KLT's pyramid absorbs the larger step, and a jump it cannot goes to the reconstruction).
  if (!session_.wants_frames() || gate_->busy()) return;
  FramePtr frame = capture_->Latest();
  if (!frame || frame->sequence <= last_tracked_sequence_) return;
  last_tracked_sequence_ = frame->sequence;
  gate_->Post(captures_, std::move(frame));
}

void Daemon::KeepRecentFrame() {
  FramePtr frame = capture_->Latest();
  if (!frame || frame->sequence <= last_recent_sequence_) return;
  last_recent_sequence_ = frame->sequence;
  const double time_s = FrameTimeSeconds(*frame);
  if (recent_frames_.Keeps(time_s)) recent_frames_.Add(ToGray(frame->image), time_s);
}

double Daemon::FrameTimeSeconds(const Frame& frame) {
  return 1e-9 * static_cast<double>(frame.capture_time_ns);
}

void Daemon::OnGateDone() {
  if (std::optional<TrackedFrame> tracked = gate_->Take()) {
    if (tracked->capture_id == captures_) ApplyGate(*tracked);
  }
  OnFrame();  // A newer frame may be waiting.
}

// Before the session's gate-touching calls (OnResult): the frame in the gate finishes, and its
// decision is applied first (with a B in flight, it only keeps the tracks or marks them lost).
void Daemon::SettleGate() {
  gate_->WaitIdle();
  if (std::optional<TrackedFrame> tracked = gate_->Take()) {
    if (tracked->capture_id == captures_) ApplyGate(*tracked);
  }
}

void Daemon::ApplyGate(const TrackedFrame& tracked) {
  if (!session_.open()) return;
  if (!tracked.error.empty()) {
    if (state_ == State::kTracking) {
      EndCapture("frame does not fit the calibration: " + tracked.error);
    }
    return;
  }
  const FramePtr& frame = tracked.frame;
  const CaptureSession::Step step =
      session_.OnTracked(tracked.decision, frame->sequence, NowSeconds(),
                         /*can_submit=*/state_ == State::kTracking);
  const GateDecision& d = session_.last_decision();
  spdlog::debug("capture {}: frame {}: {} tracks, parallax {:.3f} deg: {}", captures_,
                frame->sequence, d.tracks, d.median_parallax_deg, d.reason);
  if (step == CaptureSession::Step::kFailed) {
    EndCapture(session_.failure_reason());
    return;
  }
  if (step != CaptureSession::Step::kSubmitB) {
    const auto now = std::chrono::steady_clock::now();
    if (state_ == State::kTracking && now - last_gate_event_ >= kGateEventPeriod) {
      last_gate_event_ = now;
      Emit({{"event", "gate"},
            {"capture", captures_},
            {"frame", frame->sequence},
            {"tracks", d.tracks},
            {"parallax_deg", d.median_parallax_deg},
            {"target_deg", config_.gate.parallax_deg},
            {"reason", d.reason}});
    }
    return;
  }
  const std::string try_note =
      session_.tries().size() > 1 ? fmt::format(" (try {})", session_.tries().size()) : "";
  if (session_.tries().back().after_lost_track) {
    spdlog::info("capture {}: keyframe B = frame {} ({}) as the tracks broke ({}){}", captures_,
                 frame->sequence, frame->source_id, d.reason, try_note);
  } else {
    spdlog::info("capture {}: keyframe B = frame {} ({}), parallax {:.2f} deg, {} inliers{}",
                 captures_, frame->sequence, frame->source_id, d.median_parallax_deg,
                 d.essential_inliers, try_note);
  }
  Emit({{"event", "keyframe_b"},
        {"capture", captures_},
        {"frame", frame->sequence},
        {"source", frame->source_id},
        {"parallax_deg", d.median_parallax_deg},
        {"inliers", d.essential_inliers},
        {"after_lost_track", session_.tries().back().after_lost_track},
        {"try", session_.tries().size()}});
  Job job{captures_,          keyframe_a_,         frame,
          undistorted_a_,     tracked.undistorted, session_.Tracks(),
          session_.Between(), session_.tries()};
  if (!worker_->Submit(std::move(job))) {
    EndCapture("worker busy; capture dropped");
    return;
  }
  SetState(State::kReconstructing);
}

void Daemon::OnJobDone() {
  SettleGate();  // OnResult may raise the gate's target.
  while (std::optional<JobOutcome> o = worker_->TakeOutcome()) {
    if (o->capture_id != captures_ || !session_.open()) continue;  // A capture already ended.
    if (o->refused) {
      const CaptureSession::Step step = session_.OnResult(false, o->failure, o->refusal);
      if (step == CaptureSession::Step::kWait && stopping_) {
        spdlog::warn("capture {} abandoned: keyframe B refused ({}) while stopping", o->capture_id,
                     o->refusal);
        Emit({{"event", "capture_abandoned"},
              {"capture", o->capture_id},
              {"error", "keyframe B refused (" + o->refusal + ") while stopping"}});
        continue;
      }
      if (step == CaptureSession::Step::kWait) {
        spdlog::info("capture {}: keyframe B refused ({}); tracking on for a later B",
                     o->capture_id, o->refusal);
        Emit({{"event", "keyframe_b_refused"}, {"capture", o->capture_id}, {"reason", o->refusal}});
        SetState(State::kTracking);
        OnFrame();
        continue;
      }
      EndCapture(session_.failure_reason());
      continue;
    }
    session_.OnResult(true, TwoViewFailure::kNone, {});
    if (o->ok) {
      ++succeeded_;
      spdlog::info("capture {}: mesh written to {} ({:.2f} s, {} B tried)", o->capture_id, o->entry,
                   o->seconds, session_.tries().size());
      Emit({{"event", "entry"},
            {"capture", o->capture_id},
            {"entry", o->entry},
            {"seconds", o->seconds},
            {"b_tries", session_.tries().size()}});
      LogHookStart(hooks_.OnEntry(o->entry, o->capture_id));
    } else {
      spdlog::error("capture {}: {}", o->capture_id, o->error);
      Emit({{"event", "capture_failed"}, {"capture", o->capture_id}, {"error", o->error}});
      LogHookStart(hooks_.OnFailure(o->error, o->capture_id));
    }
    last_result_ = {{"capture", o->capture_id}, {"ok", o->ok},
                    {"entry", o->entry},        {"error", o->error},
                    {"seconds", o->seconds},    {"b_tries", session_.tries().size()}};
    keyframe_a_.reset();
    undistorted_a_.release();
    SetState(State::kIdle);
  }
}

}  // namespace mm::daemon_detail
