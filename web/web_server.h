#pragma once
// WebServer: monomesh-web's HTTP side (cpp-httplib): the page files, three.js under /three/,
// and the JSON API of docs/web.md over the spool (read only) and the daemon (DaemonLink).
// GET never changes state; a POST (/api/trigger, /api/walk/start, /api/walk/stop) needs the
// bearer token. Requests are bounded:
// body size, header count, URI length (httplib's 8 KiB), a deadline for each request to
// arrive whole (BoundedServer), read, write and keep-alive timeouts, the number of worker
// threads and of event-stream clients.
//
// Thread-safety: Listen blocks on its thread; Stop may be called from any thread.

#include <cstddef>
#include <filesystem>
#include <memory>
#include <string>

#include "web/daemon_link.h"
#include "web/event_hub.h"

namespace httplib {
class Server;
}

namespace mm {

class BoundedServer;

struct WebServerOptions {
  std::string host = "127.0.0.1";
  int port = 8080;  ///< 0: any free port (port() says which).
  std::filesystem::path spool_dir;
  std::filesystem::path static_dir;  ///< index.html, viewer.html, app.js, ...
  std::filesystem::path three_dir;   ///< Debian's libjs-three, served under /three/.
  std::string token;                 ///< The bearer token POSTs must carry (not empty).
  /// HTTP worker threads: each connection holds one while it is open (cpp-httplib), so this
  /// bounds the slow clients that can be served at once.
  size_t threads = 64;
  size_t max_body_bytes = 64 * 1024;
  size_t max_headers = 100;
  int read_timeout_s = 5;       ///< Per read and per write.
  int request_deadline_s = 10;  ///< A request's line, headers and body arrive within it.
  EventHubOptions events;
  [[nodiscard]] std::string Check() const;
};

class WebServer {
 public:
  WebServer(WebServerOptions options, DaemonLink& link);
  ~WebServer();
  WebServer(const WebServer&) = delete;
  WebServer& operator=(const WebServer&) = delete;

  /// Binds the address; "" or the error (naming the address).
  [[nodiscard]] std::string Bind();
  /// The port bound (after Bind).
  [[nodiscard]] int port() const { return port_; }
  /// Serves until Stop (after Bind).
  void Listen();
  /// Ends event streams and stops serving (idempotent).
  void Stop();

 private:
  void Routes();

  WebServerOptions options_;
  DaemonLink& link_;
  EventHub hub_;
  std::unique_ptr<BoundedServer> server_;
  int port_ = 0;
};

/// Whether `header` is "Bearer TOKEN" with this token (compared in constant time).
[[nodiscard]] bool BearerTokenMatches(const std::string& header, const std::string& token);

}  // namespace mm
