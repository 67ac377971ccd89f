// The control protocol's verbs (docs/control.md): trigger, status, ping, odom, walk start and
// walk stop, each answered with one JSON object. `watch` is served in events.cc.

#include "app/daemon_loop.h"

#include <optional>

#include "scale/metric_scale.h"
#include "scale/odometry.h"

namespace mm::daemon_detail {

json Daemon::OnOdom(const std::string& line) {
  std::string error;
  const std::optional<OdometrySample> sample = ParseOdometryLine(OdomArguments(line), &error);
  if (!sample) return {{"ok", false}, {"error", "odom: " + error}};
  odometry_.Add(*sample);
  return {{"ok", true}};
}

json Daemon::Answer(const std::string& request) {
  switch (ParseControlCommand(request)) {
    case ControlCommand::kTrigger: {
      json reply;
      OnTrigger("control socket", &reply);
      return reply;
    }
    case ControlCommand::kStatus:
      return Status();
    case ControlCommand::kPing:
      return {{"ok", true}};
    case ControlCommand::kOdom:
      return OnOdom(request);
    case ControlCommand::kWalkStart:
      return OnWalkStart("control socket");
    case ControlCommand::kWalkStop:
      return OnWalkStop("control socket", "operator");
    case ControlCommand::kWatch:  // Served by OnClient (the connection stays).
    case ControlCommand::kUnknown:
      break;
  }
  return {{"ok", false}, {"error", UnknownControlCommandError(request)}};
}

json Daemon::Status() {
  const CaptureStats stats = capture_->stats();
  return {{"ok", true},
          {"state", Name(state_)},
          {"captures", captures_},
          {"last_trigger", last_trigger_},
          {"triggers",
           [this] {
             json list = json::array();
             for (const auto& t : triggers_) list.push_back(t->Describe());
             list.push_back("control socket " + config_.control_socket.string());
             return list;
           }()},
          {"meshes", succeeded_},
          {"camera",
           {{"source", capture_->Describe()},
            {"frames", stats.frames},
            {"frame_rate_hz", stats.frame_rate_hz},
            {"dropped", stats.dropped},
            {"errors", stats.errors},
            {"end_of_stream", stats.end_of_stream},
            {"last_error", stats.last_error}}},
          {"gate",
           {{"tracks", session_.last_decision().tracks},
            {"parallax_deg", session_.last_decision().median_parallax_deg},
            {"essential_inliers", session_.last_decision().essential_inliers},
            {"homography_inliers", session_.last_decision().homography_inliers},
            {"b_tries", session_.tries().size()},
            {"reason", session_.last_decision().reason}}},
          {"scale",
           {{"source", ScaleSourceName(config_.scale.source)}, {"odometry", odometry_.Describe()}}},
          {"walk",
           [this] {
             json walk = WalkStatusJson(walk_->status());
             walk["last_result"] = last_walk_;
             return walk;
           }()},
          {"spool", spool_.dir().string()},
          {"last_result", last_result_}};
}

}  // namespace mm::daemon_detail
