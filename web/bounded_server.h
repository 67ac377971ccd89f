#pragma once
// BoundedServer: an httplib::Server (cpp-httplib 0.11) whose connections must deliver each
// request (request line, headers and body) within a deadline. httplib's own read timeout is
// per read: a client that sends one byte every few seconds and never ends its header holds a
// worker thread for as long as it likes (a "drip" slowloris). Here each request's reads share
// one deadline, after which the connection is closed. Responses are not bounded by it (an
// event stream writes for as long as the client reads), only by the write timeout per write.
//
// Thread-safety: as httplib::Server (each connection is served on one worker thread).

#include <httplib.h>

#include <chrono>

namespace mm {

struct BoundedServerOptions {
  std::chrono::milliseconds request_deadline{10000};   ///< From a request's first byte to its end.
  std::chrono::milliseconds read_timeout{5000};        ///< Per read (also httplib's).
  std::chrono::milliseconds write_timeout{5000};       ///< Per write.
  std::chrono::milliseconds keep_alive_timeout{1000};  ///< For the next request on a connection.
  size_t keep_alive_max_count = 5;                     ///< Requests per connection.
  /// Connections the kernel queues before they are accepted. httplib (built into Debian's
  /// libcpp-httplib with a backlog of 5) overflows on a burst, and a client whose handshake
  /// the kernel dropped waits seconds for a SYN-ACK retransmission.
  int listen_backlog = 256;
};

class BoundedServer : public httplib::Server {
 public:
  explicit BoundedServer(const BoundedServerOptions& options);

  /// After bind_to_port: re-listens with options.listen_backlog (listen(2) on a listening
  /// socket sets its backlog). False with errno on failure.
  bool ApplyListenBacklog();

 private:
  // Replaces httplib's connection loop (its SocketStream has no deadline); the request
  // parsing, routing and response writing stay httplib's (process_request).
  bool process_and_close_socket(socket_t sock) override;

  BoundedServerOptions options_;
};

}  // namespace mm
