#include "web/web_server.h"

#include <fcntl.h>
#include <httplib.h>
#include <sys/stat.h>
#include <unistd.h>

#include <spdlog/spdlog.h>
#include <cerrno>
#include <cstring>
#include <nlohmann/json.hpp>

#include "base/text_file.h"
#include "base/unique_fd.h"
#include "web/bounded_server.h"
#include "web/entry_index.h"

namespace mm {
namespace fs = std::filesystem;
using json = nlohmann::json;
using namespace std::chrono_literals;

namespace {

void SendJson(httplib::Response& res, int status, const json& body) {
  res.status = status;
  res.set_header("Cache-Control", "no-store");
  res.set_content(body.dump(), "application/json");
}

void SendError(httplib::Response& res, int status, const std::string& message) {
  SendJson(res, status, json{{"error", message}});
}

// The daemon's reply line as the answer: it is JSON already (docs/control.md).
void SendDaemonReply(httplib::Response& res, DaemonLink& link, const std::string& command) {
  std::string reply;
  try {
    reply = link.Request(command);
  } catch (const std::exception& e) {
    SendError(res, 503, std::string("daemon: ") + e.what());
    return;
  }
  const json j = json::parse(reply, nullptr, /*allow_exceptions=*/false);
  if (j.is_discarded()) {
    SendError(res, 502, "daemon: the reply is not JSON");
    return;
  }
  SendJson(res, 200, j);
}

const char* ContentTypeOf(const std::string& file) {
  const std::string ext = fs::path(file).extension().string();
  if (ext == ".glb") return "model/gltf-binary";
  if (ext == ".png") return "image/png";
  if (ext == ".jpg") return "image/jpeg";
  if (ext == ".json") return "application/json";
  if (ext == ".txt" || ext == ".toml" || ext == ".obj" || ext == ".mtl") {
    return "text/plain; charset=utf-8";
  }
  return "application/octet-stream";
}

// Streams an open file (the entry may be removed by retention meanwhile: the descriptor
// keeps the bytes).
void SendFile(httplib::Response& res, UniqueFd fd, size_t size, const char* content_type) {
  auto file = std::make_shared<UniqueFd>(std::move(fd));
  res.set_content_provider(
      size, content_type, [file](size_t offset, size_t length, httplib::DataSink& sink) {
        char buf[64 * 1024];
        const ssize_t n =
            ::pread(file->get(), buf, std::min(length, sizeof(buf)), static_cast<off_t>(offset));
        if (n <= 0) return false;  // Shorter than at open: end the response.
        return sink.write(buf, static_cast<size_t>(n));
      });
}

// The message of an error answer httplib makes by itself (the handlers above name their own).
std::string ErrorMessage(int status, size_t max_body_bytes) {
  switch (status) {
    case 400:
      return "bad request: the request line, a header or the body does not parse";
    case 404:
      return "no such resource for this method (docs/web.md lists the API)";
    case 413:
      return "the body is larger than " + std::to_string(max_body_bytes) + " bytes";
    case 414:
      return "the request's URI is too long";
    case 416:
      return "the requested range is not satisfiable";
    case 500:
      return "internal error";
    default:
      return "HTTP " + std::to_string(status);
  }
}

// The SSE keep-alive: a comment line after this long without a message, so a client that went
// away is noticed (the write fails) and proxies keep the stream open.
constexpr auto kHeartbeat = 10s;

}  // namespace

bool BearerTokenMatches(const std::string& header, const std::string& token) {
  static const std::string kScheme = "Bearer ";
  if (token.empty() || header.size() != kScheme.size() + token.size() ||
      header.compare(0, kScheme.size(), kScheme) != 0) {
    return false;
  }
  unsigned char diff = 0;  // Every byte compared: the time says nothing about the token.
  for (size_t i = 0; i < token.size(); ++i) {
    diff |= static_cast<unsigned char>(header[kScheme.size() + i] ^ token[i]);
  }
  return diff == 0;
}

std::string WebServerOptions::Check() const {
  if (port < 0 || port > 65535) return "port: " + std::to_string(port) + " is not 0 to 65535";
  if (spool_dir.empty()) return "spool_dir: empty";
  if (token.empty()) return "token: empty (POSTs could not be authorised)";
  if (threads < 4) return "threads: at least 4";
  if (read_timeout_s < 1) return "read_timeout_s: at least 1";
  if (request_deadline_s < read_timeout_s) {
    return "request_deadline_s: at least read_timeout_s (" + std::to_string(read_timeout_s) + ")";
  }
  if (events.max_clients + 2 > threads) {
    return "events.max_clients: must leave at least 2 of the " + std::to_string(threads) +
           " threads to other requests";
  }
  return {};
}

WebServer::WebServer(WebServerOptions options, DaemonLink& link)
    : options_(std::move(options)),
      link_(link),
      hub_(link_, options_.events),
      server_(std::make_unique<BoundedServer>(BoundedServerOptions{
          .request_deadline = std::chrono::seconds(options_.request_deadline_s),
          .read_timeout = std::chrono::seconds(options_.read_timeout_s),
          .write_timeout = std::chrono::seconds(options_.read_timeout_s),
          // An idle keep-alive connection holds a worker: short, and a few requests each.
          .keep_alive_timeout = std::chrono::seconds(1),
          .keep_alive_max_count = 5})) {
  Routes();
}

WebServer::~WebServer() { Stop(); }

void WebServer::Routes() {
  httplib::Server& s = *server_;
  const size_t threads = options_.threads;
  s.new_task_queue = [threads] { return new httplib::ThreadPool(threads); };
  s.set_payload_max_length(options_.max_body_bytes);
  s.set_default_headers({{"X-Content-Type-Options", "nosniff"},
                         {"X-Frame-Options", "DENY"},
                         {"Referrer-Policy", "no-referrer"}});

  const size_t max_headers = options_.max_headers;
  s.set_pre_routing_handler([max_headers](const httplib::Request& req, httplib::Response& res) {
    if (req.headers.size() > max_headers) {
      SendError(res, 431, "more than " + std::to_string(max_headers) + " header fields");
      return httplib::Server::HandlerResponse::Handled;
    }
    return httplib::Server::HandlerResponse::Unhandled;
  });
  s.set_exception_handler(
      [](const httplib::Request& req, httplib::Response& res, std::exception_ptr ep) {
        std::string what = "unknown";
        try {
          std::rethrow_exception(ep);
        } catch (const std::exception& e) {
          what = e.what();
        } catch (...) {
        }
        spdlog::error("web: {} {}: {}", req.method, req.path, what);
        SendError(res, 500, "internal error");
      });
  // Every error answer carries a JSON body with a message (docs/web.md): httplib's own (a
  // request that does not parse, an unknown path, a body too large) come without one.
  const size_t max_body = options_.max_body_bytes;
  // Handled, so httplib frames it (Content-Length); it also applies a Range header to it.
  s.set_error_handler(
      httplib::Server::Handler([max_body](const httplib::Request&, httplib::Response& res) {
        if (res.body.empty() && !res.has_header("Content-Type")) {
          SendError(res, res.status, ErrorMessage(res.status, max_body));
        }
      }));
  s.set_logger([](const httplib::Request& req, const httplib::Response& res) {
    spdlog::debug("web: {} {} {} {}", req.remote_addr, req.method, req.path, res.status);
  });

  s.Get("/api/status", [this](const httplib::Request&, httplib::Response& res) {
    SendDaemonReply(res, link_, "status");
  });
  s.Get("/api/entries", [this](const httplib::Request&, httplib::Response& res) {
    SendJson(res, 200, ListEntrySummaries(options_.spool_dir));
  });
  s.Get(R"(/api/entries/([^/]+))", [this](const httplib::Request& req, httplib::Response& res) {
    const std::optional<fs::path> entry = FindEntry(options_.spool_dir, req.matches[1].str());
    const std::optional<fs::path> file =
        entry ? FindEntryFile(*entry, "report.json") : std::nullopt;
    if (!file) return SendError(res, 404, "no such entry");
    std::string error;
    const std::optional<std::string> text = ReadTextFile(*file, kMaxDataFileBytes, &error);
    if (!text) return SendError(res, 404, "the entry's report cannot be read");
    res.set_header("Cache-Control", "no-store");
    res.set_content(*text, "application/json");
  });
  s.Get(R"(/api/entries/([^/]+)/([^/]+))", [this](const httplib::Request& req,
                                                  httplib::Response& res) {
    const std::optional<fs::path> entry = FindEntry(options_.spool_dir, req.matches[1].str());
    if (!entry) return SendError(res, 404, "no such entry");
    const std::string name = req.matches[2].str();
    // Named after the entry and the file as the listings have them, set once found: the
    // request's own bytes never reach a header.
    const auto attachment = [&](const std::string& file) {
      if (req.get_param_value("download") != "1") return;
      res.set_header("Content-Disposition",
                     "attachment; filename=\"" + entry->filename().string() + "-" + file + "\"");
    };
    if (name == "obj.zip") {
      std::string error;
      const std::optional<std::string> zip = ZipObjFiles(*entry, &error);
      if (!zip) {
        spdlog::warn("web: {}", error);
        return SendError(res, 404, "the entry has no complete OBJ mesh");
      }
      attachment("obj.zip");
      res.set_content(*zip, "application/zip");
      return;
    }
    const std::optional<fs::path> file = FindEntryFile(*entry, name);
    if (!file) return SendError(res, 404, "no such file in the entry");
    UniqueFd fd(::open(file->c_str(), O_RDONLY | O_CLOEXEC | O_NOFOLLOW));
    struct stat st {};
    if (!fd.valid() || ::fstat(fd.get(), &st) != 0 || !S_ISREG(st.st_mode)) {
      return SendError(res, 404, "no such file in the entry");
    }
    attachment(file->filename().string());
    SendFile(res, std::move(fd), static_cast<size_t>(st.st_size), ContentTypeOf(name));
  });
  // Every POST changes state: the token first, then the daemon's own answer.
  const auto authorised = [this](const httplib::Request& req, httplib::Response& res) {
    if (BearerTokenMatches(req.get_header_value("Authorization"), options_.token)) return true;
    res.set_header("WWW-Authenticate", "Bearer");
    SendError(res, 401, "a POST needs the token: Authorization: Bearer TOKEN");
    return false;
  };
  s.Post("/api/trigger", [this, authorised](const httplib::Request& req, httplib::Response& res) {
    if (!authorised(req, res)) return;
    spdlog::info("web: capture pressed by {}", req.remote_addr);
    SendDaemonReply(res, link_, "trigger");
  });
  // The action is one of the two the pattern admits; nothing else of the path is used.
  s.Post(R"(/api/walk/(start|stop))",
         [this, authorised](const httplib::Request& req, httplib::Response& res) {
           if (!authorised(req, res)) return;
           const std::string command = "walk " + req.matches[1].str();
           spdlog::info("web: {} pressed by {}", command, req.remote_addr);
           SendDaemonReply(res, link_, command);
         });
  s.Get("/api/events", [this](const httplib::Request&, httplib::Response& res) {
    std::shared_ptr<EventHub::Client> client = hub_.Subscribe();
    if (!client) {
      return SendError(
          res, 503, "too many event streams (" + std::to_string(options_.events.max_clients) + ")");
    }
    // The state now, then every event from here on (the hub queues them meanwhile).
    std::string first;
    try {
      first = EventHub::StatusMessage(link_.Request("status"));
    } catch (const std::exception&) {
      first = EventHub::kDaemonGoneMessage;
    }
    res.set_header("Cache-Control", "no-store");
    res.set_chunked_content_provider(
        "text/event-stream",
        [client, first, sent = false, last_write = std::chrono::steady_clock::now()](
            size_t, httplib::DataSink& sink) mutable {
          if (!sent) {
            sent = true;
            return sink.write(first.data(), first.size());
          }
          bool closed = false;
          const std::optional<std::string> message = client->Next(1000ms, &closed);
          if (closed) {
            sink.done();
            return true;
          }
          const auto now = std::chrono::steady_clock::now();
          if (message) {
            last_write = now;
            return sink.write(message->data(), message->size());
          }
          if (now - last_write >= kHeartbeat) {
            last_write = now;
            static constexpr char kComment[] = ": keep-alive\n\n";
            return sink.write(kComment, sizeof(kComment) - 1);
          }
          return sink.is_writable();
        },
        [this, client](bool) { hub_.Unsubscribe(client); });
  });

  if (!options_.three_dir.empty()) s.set_mount_point("/three", options_.three_dir.string());
  if (!options_.static_dir.empty()) s.set_mount_point("/", options_.static_dir.string());
}

std::string WebServer::Bind() {
  if (std::string problem = options_.Check(); !problem.empty()) return problem;
  const std::string address = options_.host + ":" + std::to_string(options_.port);
  if (options_.port == 0) {
    port_ = server_->bind_to_any_port(options_.host);
    if (port_ <= 0) return address + ": cannot bind: " + std::strerror(errno);
  } else {
    if (!server_->bind_to_port(options_.host, options_.port)) {
      return address + ": cannot bind: " + std::strerror(errno);
    }
    port_ = options_.port;
  }
  if (!server_->ApplyListenBacklog()) {
    return address + ": cannot listen: " + std::strerror(errno);
  }
  hub_.Start();
  return {};
}

void WebServer::Listen() { server_->listen_after_bind(); }

void WebServer::Stop() {
  hub_.Stop();
  server_->stop();
}

}  // namespace mm
