#include "app/control_protocol.h"

#include <algorithm>

namespace mm {

ControlRequestReader::Status ControlRequestReader::Append(std::string_view bytes) {
  if (status_ == Status::kTooLong) return status_;
  pending_.append(bytes);
  return status_ == Status::kComplete ? status_ : Scan();
}

ControlRequestReader::Status ControlRequestReader::Finish() {
  finished_ = true;
  return status_ == Status::kNeedMore ? Scan() : status_;
}

ControlRequestReader::Status ControlRequestReader::Next() {
  if (status_ != Status::kComplete) return status_;
  request_.clear();
  return Scan();
}

ControlRequestReader::Status ControlRequestReader::Scan() {
  const size_t end = pending_.find('\n');
  if (end == std::string::npos) {
    if (pending_.size() > max_bytes_) {
      pending_.clear();
      return status_ = Status::kTooLong;
    }
    if (!finished_) return status_ = Status::kNeedMore;
    if (pending_.empty()) return status_ = Status::kEmpty;
    request_ = std::move(pending_);
    pending_.clear();
    return status_ = Status::kComplete;
  }
  if (end > max_bytes_) {
    pending_.clear();
    return status_ = Status::kTooLong;
  }
  request_.assign(pending_, 0, end);
  pending_.erase(0, end + 1);
  return status_ = Status::kComplete;
}

namespace {

std::string_view WithoutCarriageReturn(std::string_view line) {
  if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
  return line;
}

}  // namespace

ControlCommand ParseControlCommand(std::string_view line) {
  line = WithoutCarriageReturn(line);
  if (line == "trigger") return ControlCommand::kTrigger;
  if (line == "status") return ControlCommand::kStatus;
  if (line == "ping") return ControlCommand::kPing;
  if (line == "watch") return ControlCommand::kWatch;
  if (line == "walk start") return ControlCommand::kWalkStart;
  if (line == "walk stop") return ControlCommand::kWalkStop;
  if (line.starts_with("odom ")) return ControlCommand::kOdom;
  return ControlCommand::kUnknown;
}

std::string_view OdomArguments(std::string_view line) {
  line = WithoutCarriageReturn(line);
  return line.starts_with("odom ") ? line.substr(5) : std::string_view();
}

std::string UnknownControlCommandError(std::string_view request) {
  return "unknown command '" + std::string(request) +
         "' (known: trigger, status, ping, odom, watch, walk start, walk stop)";
}

}  // namespace mm
