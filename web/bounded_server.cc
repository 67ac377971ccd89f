#include "web/bounded_server.h"

#include <arpa/inet.h>
#include <netdb.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <cerrno>
#include <cstring>
#include <string>
#include <string_view>

#include "base/poll.h"

namespace mm {
namespace {

using Clock = std::chrono::steady_clock;

// The numeric address of one end of `fd`: `get` is getpeername or getsockname.
void SocketAddress(int fd, decltype(&::getpeername) get, std::string* ip, int* port) {
  sockaddr_storage address{};
  socklen_t length = sizeof(address);
  if (get(fd, reinterpret_cast<sockaddr*>(&address), &length) != 0) return;
  std::array<char, NI_MAXHOST> host{};
  if (getnameinfo(reinterpret_cast<const sockaddr*>(&address), length, host.data(),
                  static_cast<socklen_t>(host.size()), nullptr, 0, NI_NUMERICHOST) == 0) {
    *ip = host.data();
  }
  if (address.ss_family == AF_INET) {
    *port = ntohs(reinterpret_cast<const sockaddr_in*>(&address)->sin_port);
  } else if (address.ss_family == AF_INET6) {
    *port = ntohs(reinterpret_cast<const sockaddr_in6*>(&address)->sin6_port);
  }
}

// Whether PollFor's answer has `event` (its -1, an error, has every bit set).
bool Has(int revents, short event) { return revents > 0 && (revents & event) != 0; }

// A connected socket as httplib's Stream, its reads bounded by a per-read timeout and by the
// current request's deadline, buffered (httplib reads the request line and headers a byte at
// a time).
class DeadlineStream final : public httplib::Stream {
 public:
  DeadlineStream(int fd, const BoundedServerOptions& options) : fd_(fd), options_(options) {}

  // Waits up to the keep-alive timeout for the next request's first byte.
  bool WaitForRequest() {
    if (begin_ < end_) return true;
    return Has(PollReadable(fd_, Clock::now() + options_.keep_alive_timeout), POLLIN);
  }
  void StartRequest() {
    deadline_ = Clock::now() + options_.request_deadline;
    head_ = Head::kRequestLine;
    line_.clear();
    framed_ = false;
  }
  // Whether a read failed (the deadline, the read timeout, an error or the peer's end): httplib
  // then answers 400 and would go on reading the rest of a drip as the next request, so the
  // connection ends instead.
  [[nodiscard]] bool ReadFailed() const { return read_failed_; }

  bool is_readable() const override {
    if (begin_ < end_) return true;
    // Past the deadline nothing more is read, even bytes already waiting. Whether the poll
    // waits for the deadline or for the read timeout is decided here, not from the clock after
    // it (poll's millisecond timeout may end a hair before the deadline).
    const Clock::time_point now = Clock::now();
    if (now < deadline_) {
      const Clock::time_point limit = std::min(deadline_, now + options_.read_timeout);
      if (Has(PollFor(fd_, POLLIN, limit), POLLIN)) return true;
    }
    read_failed_ = true;
    return false;
  }
  bool is_writable() const override {
    return Has(PollFor(fd_, POLLOUT, Clock::now() + options_.write_timeout), POLLOUT);
  }

  ssize_t read(char* ptr, size_t size) override {
    // RFC 9112 6.3: a request with neither Content-Length nor Transfer-Encoding has no body.
    // httplib 0.11 reads such a POST's body to the end of the connection instead (`curl -X
    // POST` without data waited for the read timeout and got an empty 400).
    if (head_ == Head::kDone && !framed_) return 0;
    if (begin_ == end_) {
      if (!is_readable()) return -1;  // The request's deadline or the read timeout passed.
      ssize_t n = 0;
      do {
        n = ::recv(fd_, buffer_.data(), buffer_.size(), 0);
      } while (n < 0 && errno == EINTR);
      if (n <= 0) {
        read_failed_ = true;
        return n;
      }
      begin_ = 0;
      end_ = static_cast<size_t>(n);
    }
    // Up to the end of the request's header (httplib reads it a byte at a time), one byte at
    // a time here too, so no byte of a body is handed over with the header's last.
    const size_t n = std::min(head_ == Head::kDone ? size : size_t{1}, end_ - begin_);
    std::memcpy(ptr, buffer_.data() + begin_, n);
    begin_ += n;
    if (head_ != Head::kDone) See(*ptr);
    return static_cast<ssize_t>(n);
  }

  ssize_t write(const char* ptr, size_t size) override {
    if (!is_writable()) return -1;
    ssize_t n = 0;
    do {
      n = ::send(fd_, ptr, size, MSG_NOSIGNAL);
    } while (n < 0 && errno == EINTR);
    return n;
  }

  // Follows the request's header line by line: whether it frames a body, and where it ends.
  void See(char byte) {
    if (line_.size() < kFramingNameMax) line_.push_back(byte);
    if (byte != '\n') return;
    if (head_ == Head::kRequestLine) {
      head_ = Head::kFields;
    } else if (line_ == "\r\n" || line_ == "\n") {
      head_ = Head::kDone;
    } else {
      const auto starts = [this](std::string_view name) {
        return line_.size() > name.size() &&
               std::equal(name.begin(), name.end(), line_.begin(), [](char a, char b) {
                 return std::tolower(static_cast<unsigned char>(b)) == a;
               });
      };
      framed_ = framed_ || starts("content-length:") || starts("transfer-encoding:");
    }
    line_.clear();
  }

  void get_remote_ip_and_port(std::string& ip, int& port) const override {
    SocketAddress(fd_, &::getpeername, &ip, &port);
  }
  void get_local_ip_and_port(std::string& ip, int& port) const override {
    SocketAddress(fd_, &::getsockname, &ip, &port);
  }
  socket_t socket() const override { return fd_; }

 private:
  int fd_;
  const BoundedServerOptions& options_;
  Clock::time_point deadline_ = Clock::time_point::max();
  mutable bool read_failed_ = false;
  std::array<char, 4096> buffer_{};
  size_t begin_ = 0;
  size_t end_ = 0;
  enum class Head { kRequestLine, kFields, kDone };
  static constexpr size_t kFramingNameMax = 32;  // Enough of a line for the names above.
  Head head_ = Head::kRequestLine;
  std::string line_;
  bool framed_ = false;  ///< Content-Length or Transfer-Encoding among the fields.
};

}  // namespace

BoundedServer::BoundedServer(const BoundedServerOptions& options) : options_(options) {
  const auto seconds = [](std::chrono::milliseconds t) {
    return std::pair{static_cast<time_t>(t.count() / 1000),
                     static_cast<time_t>(t.count() % 1000 * 1000)};
  };
  set_read_timeout(seconds(options_.read_timeout).first, seconds(options_.read_timeout).second);
  set_write_timeout(seconds(options_.write_timeout).first, seconds(options_.write_timeout).second);
  // Only for httplib's "Keep-Alive: timeout=N, max=M" response header; the loop below applies them.
  set_keep_alive_timeout(std::max<time_t>(1, seconds(options_.keep_alive_timeout).first));
  set_keep_alive_max_count(options_.keep_alive_max_count);
}

bool BoundedServer::ApplyListenBacklog() {
  return svr_sock_ != INVALID_SOCKET && ::listen(svr_sock_, options_.listen_backlog) == 0;
}

// The loop of httplib's process_server_socket_core, over DeadlineStream: up to
// keep_alive_max_count requests while the server runs, the last one answered with
// "Connection: close".
bool BoundedServer::process_and_close_socket(socket_t sock) {
  bool ok = false;
  {
    DeadlineStream stream(sock, options_);
    for (size_t left = options_.keep_alive_max_count; left > 0 && svr_sock_ != INVALID_SOCKET;
         --left) {
      if (!stream.WaitForRequest()) break;
      stream.StartRequest();
      bool connection_closed = false;
      ok = process_request(stream, left == 1, connection_closed, nullptr);
      if (!ok || connection_closed || stream.ReadFailed()) break;
    }
  }
  ::shutdown(sock, SHUT_RDWR);
  ::close(sock);
  return ok;
}

}  // namespace mm
