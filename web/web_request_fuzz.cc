// libFuzzer target for monomesh-web's request handling (the fuzz preset, scripts/fuzz.sh): any
// bytes arrive as one connection's request at a real WebServer over a spool with one entry.
// Whatever they are, the service answers or closes, never serves a byte of the file outside
// the spool and the page files (its marker aborts the run), and its first answer, when an
// error, carries a JSON message (docs/web.md; a HEAD's answer has no body).

#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cctype>
#include <cerrno>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <memory>
#include <string>
#include <thread>

#include "entry/report.h"
#include "web/web_server.h"

namespace {

namespace fs = std::filesystem;
constexpr char kSecret[] = "FUZZ-SECRET-OUTSIDE-THE-SPOOL";

class NoDaemon : public mm::DaemonLink {
 public:
  std::string Request(const std::string& command) override {
    if (command == "trigger") return R"({"ok":true,"capture":1})";
    if (command.rfind("walk ", 0) == 0) return R"({"ok":true,"walk":1})";
    return R"({"ok":true,"state":"idle"})";
  }
  void Watch(const std::function<void(const std::string&)>&,
             const std::function<bool()>&) override {
    throw mm::DaemonUnreachable("no daemon in the fuzz target");
  }
};

struct Fixture {
  Fixture() {
    root = fs::temp_directory_path() / ("mm_web_fuzz_" + std::to_string(::getpid()));
    fs::remove_all(root);
    const fs::path entry = root / "spool" / "20261202T100000Z-000001";
    fs::create_directories(entry);
    fs::create_directories(root / "static");
    std::ofstream(root / "secret.txt") << kSecret;
    std::ofstream(root / "static" / "index.html") << "<html></html>";
    mm::EntryReport report;
    report.success = true;
    std::ofstream(entry / "report.json") << mm::FormatEntryReport(report);
    std::ofstream(entry / "mesh.obj") << "v 0 0 0\n";
    mm::WebServerOptions options;
    options.port = 0;
    options.spool_dir = root / "spool";
    options.static_dir = root / "static";
    options.token = "fuzz-token-0123456789";
    options.read_timeout_s = 1;
    server = std::make_unique<mm::WebServer>(options, daemon);
    if (!server->Bind().empty()) std::abort();
    thread = std::thread([this] { server->Listen(); });
  }
  fs::path root;
  NoDaemon daemon;
  std::unique_ptr<mm::WebServer> server;
  std::thread thread;  // Serves until the process ends.
};

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static Fixture* fixture = new Fixture();  // One server for the whole run.
  // Thousands of connections a second leave as many in TIME_WAIT: each comes from the next of
  // 127.0.0.1 to 127.0.0.254 (all loopback), so the 4-tuples do not run out.
  static uint32_t source = 0;
  source = source % 254 + 1;
  const int fd = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
  sockaddr_in from{};
  from.sin_family = AF_INET;
  from.sin_addr.s_addr = htonl(INADDR_LOOPBACK - 1 + source);
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_port = htons(static_cast<uint16_t>(fixture->server->port()));
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  if (::bind(fd, reinterpret_cast<const sockaddr*>(&from), sizeof(from)) != 0 ||
      ::connect(fd, reinterpret_cast<const sockaddr*>(&addr), sizeof(addr)) != 0) {
    // Refused: the server is gone, a finding. Out of addresses: not the input's doing.
    if (errno == ECONNREFUSED) std::abort();
    ::close(fd);
    return 0;
  }
  size_t sent = 0;
  while (sent < size) {
    const ssize_t n = ::send(fd, data + sent, size - sent, MSG_NOSIGNAL);
    if (n <= 0) break;  // The server closed early: a refusal.
    sent += static_cast<size_t>(n);
  }
  ::shutdown(fd, SHUT_WR);
  // The reply up to the server's close. Its read timeout is 1 s, so it closes first unless
  // the machine stalls it (a loaded CI runner): a reply cut short by our own wait is not judged.
  std::string reply;
  bool complete = false;
  char buf[16384];
  for (;;) {
    pollfd p{fd, POLLIN, 0};
    if (::poll(&p, 1, 3000) <= 0) break;
    const ssize_t n = ::recv(fd, buf, sizeof(buf), 0);
    if (n <= 0) {
      complete = n == 0;
      break;
    }
    reply.append(buf, static_cast<size_t>(n));
    if (reply.size() > (4u << 20)) break;
  }
  ::close(fd);
  if (reply.find(kSecret) != std::string::npos) std::abort();
  // A HEAD's answer has no body; httplib cuts a routed answer's body to a Range header's.
  std::string lower(reinterpret_cast<const char*>(data), size);
  for (char& c : lower) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  const bool head = lower.rfind("head", 0) == 0 || lower.find("range") != std::string::npos;
  if (complete && !head && reply.size() > 12 && reply.compare(0, 9, "HTTP/1.1 ") == 0 &&
      (reply[9] == '4' || reply[9] == '5')) {
    const size_t end = reply.find("\r\n\r\n");
    if (end == std::string::npos || reply.compare(end + 4, 10, "{\"error\":\"") != 0) {
      std::fprintf(stderr, "error answer without a JSON message (%zu bytes):\n%s\n", reply.size(),
                   reply.c_str());
      std::abort();
    }
  }
  return 0;
}
