// Walk mode on the event loop (docs/walk.md): `walk start` / `walk stop` (or a long press),
// and the walk thread's progress, keyframes and entry as they come. The walk itself runs in
// WalkThread.

#include "app/daemon_loop.h"

#include <spdlog/spdlog.h>

#include <utility>

namespace mm::daemon_detail {

json Daemon::OnWalkStart(const char* origin) {
  const auto refuse = [&](const std::string& error) {
    spdlog::warn("walk start ({}) refused: {}", origin, error);
    Emit({{"event", "walk_refused"}, {"origin", origin}, {"error", error}});
    return json{{"ok", false}, {"error", error}};
  };
  if (state_ != State::kIdle) return refuse(std::string("busy: ") + Name(state_));
  if (walk_->status().walking) return refuse("busy: the last walk's entry is being written");
  FramePtr latest = capture_->Latest();
  if (!latest) return refuse("no frame from the camera yet");
  ++walks_;
  last_walk_sequence_ = latest->sequence;
  walk_frames_seen_ = 0;
  spdlog::info("walk {} ({}): started at frame {} ({})", walks_, origin, latest->sequence,
               latest->source_id);
  Emit({{"event", "walk_started"},
        {"walk", walks_},
        {"origin", origin},
        {"frame", latest->sequence}});
  walk_->Start(walks_, std::move(latest));
  SetState(State::kWalking);
  return {{"ok", true}, {"walk", walks_}};
}

json Daemon::OnWalkStop(const char* origin, const std::string& reason) {
  if (state_ != State::kWalking) {
    const std::string error = std::string("not walking (") + Name(state_) + ")";
    spdlog::warn("walk stop ({}) refused: {}", origin, error);
    return {{"ok", false}, {"error", error}};
  }
  const WalkStatus w = walk_->status();
  if (w.finishing) return {{"ok", false}, {"error", "walk already stopping"}};
  spdlog::info("walk {}: stopped ({}, {}) after {} keyframes; writing its entry", w.walk, origin,
               reason, w.keyframes);
  Emit({{"event", "walk_stopping"},
        {"walk", w.walk},
        {"reason", reason},
        {"keyframes", w.keyframes}});
  walk_->Stop(reason);
  return {{"ok", true}, {"walk", w.walk}, {"keyframes", w.keyframes}};
}

json Daemon::WalkStatusJson(const WalkStatus& w) const {
  return json{{"walking", w.walking},
              {"finishing", w.finishing},
              {"walk", w.walking ? w.walk : walks_},
              {"frames", w.frames},
              {"keyframes", w.keyframes},
              {"registered", w.registered},
              {"segment", w.segment},
              {"segments", w.segments},
              {"relocalizations", w.relocalizations},
              {"merges", w.merges},
              {"loop_closures", w.loop_closures},
              {"lost_keyframes", w.lost_keyframes},
              {"tracked_frames", w.tracked_frames},
              {"tracking", w.tracking},
              {"parallax_deg", w.parallax_deg},
              {"target_deg", config_.walk.gate.parallax_deg},
              {"seconds", w.seconds}};
}

void Daemon::OnWalkDone() {
  // The walk's progress, at most 5 per second while it looks at new frames (as the gate's).
  if (const WalkStatus w = walk_->status();
      w.walking && !w.finishing && w.frames > walk_frames_seen_) {
    const auto now = std::chrono::steady_clock::now();
    if (now - last_walk_event_ >= kGateEventPeriod) {
      last_walk_event_ = now;
      walk_frames_seen_ = w.frames;
      json event = WalkStatusJson(w);
      event["event"] = "walk_frame";
      Emit(std::move(event));
    }
  }
  for (const WalkKeyframeSummary& k : walk_->TakeKeyframes()) {
    if (!k.failure.empty()) {
      spdlog::warn("walk {}: keyframe {} (segment {}): {}", walks_, k.index, k.segment, k.failure);
    } else if (k.relocalized_to >= 0) {
      spdlog::info(
          "walk {}: keyframe {} relocalised against keyframe {} ({} PnP inliers, {:.3f} s)", walks_,
          k.index, k.relocalized_to, k.pnp_inliers, k.time_s);
    } else {
      spdlog::info("walk {}: keyframe {} registered ({} PnP inliers, {} new points, {:.3f} s)",
                   walks_, k.index, k.pnp_inliers, k.new_points, k.time_s);
    }
    if (k.merged_segment >= 0) {
      spdlog::info("walk {}: keyframe {} merged segment {} into segment {}", walks_, k.index,
                   k.merged_segment, k.segment);
    }
    if (k.loop_to >= 0) {
      spdlog::info("walk {}: keyframe {} closed a loop with keyframe {} (moved {:.3f} map units)",
                   walks_, k.index, k.loop_to, k.loop_correction_m);
    }
    if (k.global_bundle_applied) {
      spdlog::info(
          "walk {}: keyframe {}: the segment's bundle adjustment after the loop applied "
          "({:.2f} s CPU in the background)",
          walks_, k.index, k.global_bundle_cpu_s);
    }
    Emit({{"event", "walk_keyframe"},
          {"walk", walks_},
          {"keyframe", k.index},
          {"segment", k.segment},
          {"registered", k.registered},
          {"failure", k.failure},
          {"relocalized_to", k.relocalized_to},
          {"merged_segment", k.merged_segment},
          {"loop_to", k.loop_to},
          {"global_bundle_applied", k.global_bundle_applied},
          {"pnp_inliers", k.pnp_inliers},
          {"new_points", k.new_points},
          {"seconds", k.time_s}});
  }
  while (std::optional<WalkOutcome> o = walk_->TakeOutcome()) {
    if (o->ok) {
      spdlog::info(
          "walk {}: map written to {} ({} keyframes, {} registered, {} segments; "
          "{:.2f} s; ended by {})",
          o->walk, o->entry, o->keyframes, o->registered, o->segments, o->seconds, o->stop_reason);
      Emit({{"event", "walk_entry"},
            {"walk", o->walk},
            {"entry", o->entry},
            {"keyframes", o->keyframes},
            {"registered", o->registered},
            {"segments", o->segments},
            {"reason", o->stop_reason},
            {"seconds", o->seconds}});
      LogHookStart(hooks_.OnEntry(o->entry, o->walk));
    } else {
      spdlog::error("walk {}: {}", o->walk, o->error);
      Emit({{"event", "walk_failed"}, {"walk", o->walk}, {"error", o->error}});
      LogHookStart(hooks_.OnFailure(o->error, o->walk));
    }
    last_walk_ = {{"walk", o->walk},
                  {"ok", o->ok},
                  {"entry", o->entry},
                  {"error", o->error},
                  {"reason", o->stop_reason},
                  {"keyframes", o->keyframes},
                  {"registered", o->registered},
                  {"segments", o->segments}};
    if (state_ == State::kWalking) SetState(State::kIdle);
  }
  OnFrame();  // A newer frame may be waiting.
}

}  // namespace mm::daemon_detail
