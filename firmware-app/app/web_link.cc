#include "app/web_link.h"

#include "app/control.h"

namespace mm {

std::string ControlSocketLink::Request(const std::string& command) {
  try {
    return SendControlCommand(socket_, command, timeout_);
  } catch (const ControlError& e) {
    throw DaemonUnreachable(e.what());
  }
}

void ControlSocketLink::Watch(const std::function<void(const std::string& line)>& on_line,
                              const std::function<bool()>& keep_watching) {
  try {
    WatchControlEvents(
        socket_,
        [&](const std::string& line) {
          on_line(line);
          return true;
        },
        keep_watching);
  } catch (const ControlError& e) {
    throw DaemonUnreachable(e.what());
  }
}

}  // namespace mm
