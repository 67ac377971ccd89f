#include "app/control_protocol.h"

#include <algorithm>

namespace mm {

ControlRequestReader::Status ControlRequestReader::Append(std::string_view bytes) {
  if (status_ != Status::kNeedMore) return status_;
  const size_t end = bytes.find('\n');
  // Never hold more than max_bytes_ + 1 bytes, whatever one read brings.
  const size_t wanted = end == std::string_view::npos ? bytes.size() : end;
  const size_t room = max_bytes_ + 1 - request_.size();
  request_.append(bytes.substr(0, std::min(wanted, room)));
  if (request_.size() > max_bytes_) {
    status_ = Status::kTooLong;
  } else if (end != std::string_view::npos) {
    status_ = Status::kComplete;
  }
  return status_;
}

ControlRequestReader::Status ControlRequestReader::Finish() {
  if (status_ == Status::kNeedMore) status_ = request_.empty() ? Status::kEmpty : Status::kComplete;
  return status_;
}

ControlCommand ParseControlCommand(std::string_view line) {
  if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
  if (line == "trigger") return ControlCommand::kTrigger;
  if (line == "status") return ControlCommand::kStatus;
  if (line == "ping") return ControlCommand::kPing;
  return ControlCommand::kUnknown;
}

std::string UnknownControlCommandError(std::string_view request) {
  return "unknown command '" + std::string(request) + "' (known: trigger, status, ping)";
}

}  // namespace mm
