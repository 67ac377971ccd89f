#pragma once
// The daemon's control socket: a UNIX stream socket, one request line per connection
// ("trigger", "status", "ping"), one JSON reply line, then the daemon closes the connection;
// `odom` lines may follow each other, and `watch` subscribes the connection to the daemon's
// events (docs/control.md).
// The line may arrive in pieces; it ends at '\n' or when the client shuts down writing. The
// daemon answers an error and closes a request longer than 256 bytes and one without an end of
// line within 5 s; an idle connection is closed after 5 s. It holds at most 32 connections: a
// new one beyond that is served, and the connection idle longest is answered "busy" and closed
// (a flood of idle connections cannot lock clients out). At the fd limit it stops accepting for
// 200 ms at a time instead of spinning.

#include <chrono>
#include <filesystem>
#include <functional>
#include <stdexcept>
#include <string>

#include "base/unique_fd.h"

namespace mm {

class ControlError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// The configured path cannot be the control socket (too long, or a file that is not a socket,
/// which the daemon never deletes): a configuration error, not a passing one.
class ControlPathError : public ControlError {
 public:
  using ControlError::ControlError;
};

/// The daemon accepted the request but did not answer within the timeout (busy, not gone).
class ControlTimeout : public ControlError {
 public:
  using ControlError::ControlError;
};

/// The socket file's group and permission bits ([control] group, mode).
struct ControlSocketAccess {
  std::string group;  ///< Group name; empty keeps the daemon's group.
  unsigned mode = 0660;
};

/// The socket's group or mode cannot be applied (no such group, or the daemon may not give the
/// socket to it): a configuration error naming the key.
class ControlAccessError : public ControlError {
 public:
  using ControlError::ControlError;
};

/// Whether the system knows a group of this name (getgrnam_r).
bool GroupExists(const std::string& name);

/// Creates, binds and listens on `path` (non-blocking, close-on-exec). The socket file gets
/// `access`'s group and mode after bind and before listen, so no client connects before they
/// apply. Only a stale socket (a socket file nobody accepts on: connect refused, left by a
/// crashed daemon) is replaced; a live daemon on it is a ControlError, and anything at the path
/// that is not a socket is a ControlPathError and stays untouched.
/// \throws ControlError naming the path (ControlAccessError for the group or mode).
UniqueFd ListenControlSocket(const std::filesystem::path& path,
                             const ControlSocketAccess& access = {});

/// Sends one command and returns the reply line.
/// \throws ControlError naming the socket when no daemon answers.
std::string SendControlCommand(const std::filesystem::path& path, const std::string& command,
                               std::chrono::milliseconds timeout);

/// Subscribes to the daemon's events (`watch`): `on_line` gets the subscription's reply, then
/// one JSON line per event, until it returns false or the daemon closes the connection; with
/// `keep_watching`, also once it returns false (asked at least every 250 ms).
/// \throws ControlError naming the socket when no daemon answers, or when the daemon sends
/// more than 1 MiB without an end of line.
void WatchControlEvents(const std::filesystem::path& path,
                        const std::function<bool(const std::string& line)>& on_line,
                        const std::function<bool()>& keep_watching = {});

}  // namespace mm
