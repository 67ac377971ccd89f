#pragma once
// How monomesh-web reaches the daemon: one request line and its reply, and the event stream
// (the control socket's `status`, `trigger` and `watch`, docs/control.md). The service's main
// implements it on the control socket; tests of the web logic may give a fake.
//
// Thread-safety: Request is called from many HTTP threads at once, Watch from one thread.

#include <functional>
#include <stdexcept>
#include <string>

namespace mm {

/// The daemon did not answer (not running, busy past the timeout): the message names the socket.
class DaemonUnreachable : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

class DaemonLink {
 public:
  virtual ~DaemonLink() = default;

  /// Sends one request line ("status", "trigger") and returns the daemon's reply line.
  /// \throws DaemonUnreachable
  virtual std::string Request(const std::string& command) = 0;

  /// Subscribes to the daemon's events: `on_line` gets the subscription's reply, then one JSON
  /// line per event, until the daemon closes the connection or `keep_watching` (asked at least
  /// every 250 ms) returns false. Returns normally when either happens.
  /// \throws DaemonUnreachable when there is no daemon to subscribe to
  virtual void Watch(const std::function<void(const std::string& line)>& on_line,
                     const std::function<bool()>& keep_watching) = 0;
};

}  // namespace mm
