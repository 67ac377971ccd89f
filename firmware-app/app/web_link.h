#pragma once
// ControlSocketLink: monomesh-web's DaemonLink (web/daemon_link.h) on the daemon's control
// socket (app/control.h): each Request is one connection, Watch one `watch` subscription.
//
// Thread-safety: thread-safe (no state besides the path).

#include <chrono>
#include <filesystem>

#include "web/daemon_link.h"

namespace mm {

class ControlSocketLink : public DaemonLink {
 public:
  explicit ControlSocketLink(std::filesystem::path socket,
                             std::chrono::milliseconds timeout = std::chrono::seconds(5))
      : socket_(std::move(socket)), timeout_(timeout) {}

  std::string Request(const std::string& command) override;
  void Watch(const std::function<void(const std::string& line)>& on_line,
             const std::function<bool()>& keep_watching) override;

 private:
  const std::filesystem::path socket_;
  const std::chrono::milliseconds timeout_;
};

}  // namespace mm
