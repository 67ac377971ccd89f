// The control socket's connections (docs/control.md): accept (a cap on clients, a pause when
// the fd limit is reached), the request line read across reads, `odom` lines answered on a
// connection that stays, any other request answered and the connection closed.

#include "app/daemon_loop.h"

#include <spdlog/spdlog.h>
#include <sys/epoll.h>
#include <sys/socket.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <string_view>

#include "entry/json_text.h"

namespace mm::daemon_detail {

void Daemon::OnAccept() {
  for (;;) {
    const int client = ::accept4(listen_fd_.get(), nullptr, nullptr, SOCK_NONBLOCK | SOCK_CLOEXEC);
    if (client < 0) {
      if (errno == EINTR || errno == ECONNABORTED) continue;
      if (errno == EMFILE || errno == ENFILE || errno == ENOBUFS || errno == ENOMEM) {
        PauseAccept();
      }
      return;  // EAGAIN: none pending.
    }
    UniqueFd fd(client);
    accept_failing_ = false;
    if (clients_.size() >= kMaxClients) {
      // At the cap, first read what the held clients have sent: a request waiting is served
      // and a client that hung up (a connect storm) is closed, freeing its slot.
      std::vector<int> held;
      for (const auto& [held_fd, c] : clients_) held.push_back(held_fd);
      for (int held_fd : held) OnClient(held_fd);
    }
    if (clients_.size() >= kMaxClients) {
      // Still full: the client idle longest makes room. A flood of idle connections cycles
      // through the slots while a client that asks is served.
      // Watchers are not idle (kMaxWatchers < kMaxClients leaves requests to choose from).
      const auto oldest =
          std::min_element(clients_.begin(), clients_.end(), [](const auto& a, const auto& b) {
            return std::pair(a.second.watching, a.second.last_read) <
                   std::pair(b.second.watching, b.second.last_read);
          });
      ReplyAndClose(oldest->first,
                    {{"ok", false},
                     {"error", "busy: " + std::to_string(kMaxClients) +
                                   " clients connected; this one was idle longest"}});
    }
    AddFd(client);
    clients_.emplace(
        client, Client{std::move(fd), ControlRequestReader(), std::chrono::steady_clock::now()});
  }
}

void Daemon::PauseAccept() {
  if (!accept_failing_) {
    spdlog::warn("control socket: accept: {}; accepting again every {} ms until it succeeds",
                 std::strerror(errno), kAcceptBackoff.count());
    accept_failing_ = true;
  }
  ::epoll_ctl(epoll_.get(), EPOLL_CTL_DEL, listen_fd_.get(), nullptr);
  accept_resume_ = std::chrono::steady_clock::now() + kAcceptBackoff;
}

void Daemon::CloseClient(int fd) {
  ::epoll_ctl(epoll_.get(), EPOLL_CTL_DEL, fd, nullptr);
  clients_.erase(fd);
}

void Daemon::ReplyAndClose(int fd, const json& reply) {
  const std::string line = JsonText(reply) + "\n";
  [[maybe_unused]] const ssize_t w = ::send(fd, line.data(), line.size(), MSG_NOSIGNAL);
  CloseClient(fd);
}

void Daemon::OnClient(int fd) {
  const auto it = clients_.find(fd);
  if (it == clients_.end()) return;  // Closed earlier in this batch of events.
  Client& client = it->second;
  char buf[512];
  if (client.watching) {
    // A watcher only listens: what it sends is read and dropped; its hang-up closes it.
    for (;;) {
      const ssize_t n = ::recv(fd, buf, sizeof(buf), 0);
      if (n > 0) continue;
      if (n < 0 && errno == EINTR) continue;
      if (n == 0 || (errno != EAGAIN && errno != EWOULDBLOCK)) CloseClient(fd);
      return;
    }
  }
  for (;;) {
    const ssize_t n = ::recv(fd, buf, sizeof(buf), 0);
    ControlRequestReader::Status status;
    if (n > 0) {
      client.last_read = std::chrono::steady_clock::now();
      status = client.request.Append(std::string_view(buf, static_cast<size_t>(n)));
    } else if (n == 0) {
      status = client.request.Finish();
    } else {
      if (errno == EINTR) continue;
      if (errno != EAGAIN && errno != EWOULDBLOCK) CloseClient(fd);
      return;  // EAGAIN: the rest of the line comes later.
    }
    // An `odom` line is answered and the connection stays for the next (a robot's bridge
    // writes them continuously); any other command is answered and the connection closed.
    std::string odom_replies;
    while (status == ControlRequestReader::Status::kComplete &&
           ParseControlCommand(client.request.request()) == ControlCommand::kOdom) {
      odom_replies += JsonText(OnOdom(client.request.request())) + "\n";
      status = client.request.Next();
    }
    if (!odom_replies.empty()) {
      // One send for the lines of one read. A bridge that never reads its answers loses them
      // once its socket buffer is full (EAGAIN), not its connection.
      [[maybe_unused]] const ssize_t w =
          ::send(fd, odom_replies.data(), odom_replies.size(), MSG_NOSIGNAL | MSG_DONTWAIT);
    }
    switch (status) {
      case ControlRequestReader::Status::kNeedMore:
        continue;
      case ControlRequestReader::Status::kComplete:
        if (ParseControlCommand(client.request.request()) == ControlCommand::kWatch) {
          OnWatch(fd);
        } else {
          ReplyAndClose(fd, Answer(client.request.request()));
        }
        return;
      case ControlRequestReader::Status::kTooLong:
        ReplyAndClose(fd,
                      {{"ok", false},
                       {"error", "request longer than " + std::to_string(kMaxControlRequestBytes) +
                                     " bytes without an end of line"}});
        return;
      case ControlRequestReader::Status::kEmpty:
        CloseClient(fd);
        return;
    }
  }
}

}  // namespace mm::daemon_detail
