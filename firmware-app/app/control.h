#pragma once
// The daemon's control socket: a UNIX stream socket, one request line per connection
// ("trigger", "status", "ping"), one JSON reply line.

#include <chrono>
#include <filesystem>
#include <stdexcept>
#include <string>

#include "base/unique_fd.h"

namespace mm {

class ControlError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// The daemon accepted the request but did not answer within the timeout (busy, not gone).
class ControlTimeout : public ControlError {
 public:
  using ControlError::ControlError;
};

/// Creates, binds and listens on `path` (non-blocking, close-on-exec). A stale socket file
/// left by a crashed daemon is replaced; a live daemon on it is an error.
/// \throws ControlError naming the path.
UniqueFd ListenControlSocket(const std::filesystem::path& path);

/// Sends one command and returns the reply line.
/// \throws ControlError naming the socket when no daemon answers.
std::string SendControlCommand(const std::filesystem::path& path, const std::string& command,
                               std::chrono::milliseconds timeout);

}  // namespace mm
