// WebServer against a spool folder on disk and a DaemonLink fake (the logic of the routes; the
// real daemon and a real browser are in tests/web/browser_test.py).

#include "web/web_server.h"

// Before httplib.h: it includes <resolv.h>, whose `_res` macro breaks Eigen's parameter names.
#include "entry/report.h"

#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <httplib.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <spdlog/spdlog.h>
#include <atomic>
#include <condition_variable>
#include <fstream>
#include <mutex>
#include <nlohmann/json.hpp>
#include <thread>

#include "tests/support/temp_dir.h"

namespace mm {
namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;
using namespace std::chrono_literals;

// The daemon as the control socket would answer, with the requests it got.
class FakeDaemon : public DaemonLink {
 public:
  std::string Request(const std::string& command) override {
    std::lock_guard lock(mutex_);
    requests_.push_back(command);
    if (!up_) throw DaemonUnreachable("control socket /x: connect: No such file or directory");
    if (command == "trigger") return R"({"ok":true,"capture":7})";
    if (command == "walk start") return R"({"ok":true,"walk":3})";
    if (command == "walk stop") return R"({"ok":true,"walk":3,"keyframes":12})";
    return R"({"ok":true,"state":"idle"})";
  }
  void Watch(const std::function<void(const std::string&)>& on_line,
             const std::function<bool()>& keep_watching) override {
    if (!up_) throw DaemonUnreachable("control socket /x: connect refused");
    on_line(R"({"ok":true,"watching":true,"seq":4,"status":{"state":"idle"}})");
    size_t sent = 0;
    while (keep_watching()) {
      std::unique_lock lock(mutex_);
      cv_.wait_for(lock, 50ms);
      while (sent < events_.size()) {
        const std::string line = events_[sent++];
        lock.unlock();
        on_line(line);
        lock.lock();
      }
    }
  }
  void Emit(const std::string& line) {
    std::lock_guard lock(mutex_);
    events_.push_back(line);
    cv_.notify_all();
  }
  std::vector<std::string> requests() {
    std::lock_guard lock(mutex_);
    return requests_;
  }
  std::atomic<bool> up_{true};

 private:
  std::mutex mutex_;
  std::condition_variable cv_;
  std::vector<std::string> requests_;
  std::vector<std::string> events_;
};

void WriteFile(const fs::path& path, const std::string& bytes) {
  std::ofstream(path, std::ios::binary) << bytes;
}

// An entry folder as the spool makes one, with a report and a few files.
fs::path MakeEntry(const fs::path& spool, const std::string& name, bool success) {
  const fs::path dir = spool / name;
  fs::create_directories(dir);
  EntryReport report;
  report.success = success;
  report.failure_reason = success ? "" : "too few inliers";
  report.counts.mesh_vertices = 1234;
  report.counts.mesh_triangles = 2345;
  report.meshing.mode = "dense";
  report.keyframe_a.capture_realtime_ns = 1'700'000'000'000'000'000;
  WriteFile(dir / "report.json", FormatEntryReport(report));
  WriteFile(dir / "mesh.glb", std::string("glTF\x02\0\0\0", 8) + std::string(1000, 'g'));
  WriteFile(dir / "mesh.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
  WriteFile(dir / "mesh.mtl", "newmtl m\n");
  WriteFile(dir / "texture.jpg", std::string(500, 'j'));
  return dir;
}

// One raw HTTP exchange on a fresh connection: what a hostile client sends, unaltered.
std::string RawRequest(int port, const std::string& request) {
  const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_port = htons(static_cast<uint16_t>(port));
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  std::string reply;
  if (::connect(fd, reinterpret_cast<const sockaddr*>(&addr), sizeof(addr)) == 0) {
    size_t off = 0;
    while (off < request.size()) {
      const ssize_t n = ::send(fd, request.data() + off, request.size() - off, MSG_NOSIGNAL);
      if (n <= 0) break;
      off += static_cast<size_t>(n);
    }
    char buf[4096];
    for (ssize_t n; (n = ::recv(fd, buf, sizeof(buf), 0)) > 0;) reply.append(buf, n);
  }
  ::close(fd);
  return reply;
}

int StatusOf(const std::string& reply) {
  return reply.size() > 12 ? std::atoi(reply.c_str() + 9) : 0;
}

// A walk's entry folder (docs/walk.md) with its report and map.
fs::path MakeWalkEntry(const fs::path& spool, const std::string& name) {
  const fs::path dir = spool / name;
  fs::create_directories(dir);
  WalkReport report;
  report.success = true;
  report.stop_reason = "operator";
  report.counts.keyframes = 12;
  report.counts.registered = 11;
  report.counts.segments = 2;
  report.counts.points = 3456;
  report.counts.mesh_vertices = 4567;
  report.timings_s.walk = 42.5;
  WalkReport::Keyframe first;
  first.info.capture_realtime_ns = 1'800'000'000'000'000'000;
  report.keyframes.push_back(first);
  WriteFile(dir / "report.json", nlohmann::json(ToJson(report)).dump(2));
  WriteFile(dir / "map.glb", std::string("glTF\x02\0\0\0", 8) + std::string(100, 'g'));
  WriteFile(dir / "trajectory.txt", "0 0 0 0 0 0 0 1\n");
  return dir;
}

class WebServerTest : public ::testing::Test {
 protected:
  void SetUp() override {
    // spdlog's registry is made on first use: here, on this thread, before the server's threads
    // (monomesh-web's main sets up logging first the same way).
    spdlog::set_level(spdlog::level::warn);
    root_ = test::FreshTempDir("web_server");
    spool_ = root_ / "spool";
    static_dir_ = root_ / "static";
    fs::create_directories(spool_);
    fs::create_directories(static_dir_);
    WriteFile(static_dir_ / "index.html", "<html>monomesh</html>");
    WriteFile(root_ / "secret.txt", "secret");
    older_ = MakeEntry(spool_, "20261202T100000Z-000001", false);
    newer_ = MakeEntry(spool_, "20261202T100500Z-000002", true);
    fs::create_directories(spool_ / "archive");  // Not the spool's: never served.
    WriteFile(spool_ / "archive" / "report.json", "{}");
    fs::create_symlink(root_ / "secret.txt", newer_ / "linked.txt");
    WebServerOptions options;
    options.port = 0;
    options.spool_dir = spool_;
    options.static_dir = static_dir_;
    options.token = "s3cret-token";
    options.events.retry = 100ms;
    Tune(options);
    server_ = std::make_unique<WebServer>(options, daemon_);
    ASSERT_EQ(server_->Bind(), "");
    thread_ = std::thread([this] { server_->Listen(); });
    client_ = std::make_unique<httplib::Client>("127.0.0.1", server_->port());
    client_->set_read_timeout(5, 0);
  }
  virtual void Tune(WebServerOptions& /*options*/) {}
  void TearDown() override {
    server_->Stop();
    thread_.join();
    fs::remove_all(root_);
  }

  fs::path root_, spool_, static_dir_, older_, newer_;
  FakeDaemon daemon_;
  std::unique_ptr<WebServer> server_;
  std::thread thread_;
  std::unique_ptr<httplib::Client> client_;
};

TEST_F(WebServerTest, ListsTheEntriesNewestFirstWithTheirFigures) {
  const auto res = client_->Get("/api/entries");
  ASSERT_TRUE(res);
  ASSERT_EQ(res->status, 200);
  const json list = json::parse(res->body);
  ASSERT_EQ(list["entries"].size(), 2u) << res->body;  // archive/ is not an entry.
  const json& first = list["entries"][0];
  EXPECT_EQ(first["name"], "20261202T100500Z-000002");
  EXPECT_EQ(first["success"], true);
  EXPECT_EQ(first["vertices"], 1234);
  EXPECT_EQ(first["triangles"], 2345);
  EXPECT_EQ(first["mesh_mode"], "dense");
  EXPECT_DOUBLE_EQ(first["time_unix_s"].get<double>(), 1.7e9);
  EXPECT_NE(std::find(first["files"].begin(), first["files"].end(), "mesh.glb"),
            first["files"].end());
  EXPECT_EQ(list["entries"][1]["failure_reason"], "too few inliers");
}

TEST_F(WebServerTest, ServesAnEntrysReportAndFiles) {
  auto res = client_->Get("/api/entries/20261202T100500Z-000002");
  ASSERT_TRUE(res);
  EXPECT_EQ(res->status, 200);
  EXPECT_EQ(json::parse(res->body)["counts"]["mesh_vertices"], 1234);
  res = client_->Get("/api/entries/20261202T100500Z-000002/mesh.glb?download=1");
  ASSERT_TRUE(res);
  EXPECT_EQ(res->status, 200);
  EXPECT_EQ(res->body.size(), 1008u);
  EXPECT_EQ(res->get_header_value("Content-Type"), "model/gltf-binary");
  EXPECT_EQ(res->get_header_value("Content-Disposition"),
            "attachment; filename=\"20261202T100500Z-000002-mesh.glb\"");
  res = client_->Get("/api/entries/20261202T100500Z-000002/obj.zip");
  ASSERT_TRUE(res);
  ASSERT_EQ(res->status, 200);
  EXPECT_EQ(res->body.substr(0, 4), std::string("PK\x03\x04", 4));
  for (const char* name : {"mesh.obj", "mesh.mtl", "texture.jpg"}) {
    EXPECT_NE(res->body.find(name), std::string::npos) << name;
  }
  res = client_->Get("/");
  ASSERT_TRUE(res);
  EXPECT_EQ(res->body, "<html>monomesh</html>");
}

// Every parameter, plain and percent-encoded: nothing outside the spool's entries and the page
// files is served; a symlink in an entry and a foreign folder in the spool are not the spool's.
TEST_F(WebServerTest, RefusesPathTraversalInEveryParameter) {
  const std::string entry = "20261202T100500Z-000002";
  for (const std::string& path : std::vector<std::string>{
           "/api/entries/..%2f..%2fsecret.txt", "/api/entries/%2e%2e", "/api/entries/..",
           "/api/entries/archive", "/api/entries/archive/report.json",
           "/api/entries/" + entry + "/..%2f" + entry + "%2freport.json",
           "/api/entries/" + entry + "/%2e%2e", "/api/entries/" + entry + "/../../secret.txt",
           "/api/entries/" + entry + "/linked.txt", "/api/entries/" + entry + "%00/report.json",
           "/api/entries/" + entry + "/report.json%00.png", "/../secret.txt", "/..%2fsecret.txt",
           "/%2e%2e/secret.txt", "/%2e%2e%2fsecret.txt", "/static/../../secret.txt",
           "/three/../secret.txt", "/api/entries/" + entry + "/%2e%2e%2f%2e%2e%2fsecret.txt"}) {
    const std::string reply = RawRequest(
        server_->port(), "GET " + path + " HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n");
    const int status = StatusOf(reply);
    EXPECT_TRUE(status == 400 || status == 404) << path << " -> " << reply.substr(0, 200);
    EXPECT_EQ(reply.find("secret\n"), std::string::npos) << path;
    EXPECT_EQ(reply.find("\r\n\r\nsecret"), std::string::npos) << path;
  }
}

// The request's own bytes never reach a response header (a name with CR LF would split it).
TEST_F(WebServerTest, ARequestedNameNeverReachesAHeader) {
  const std::string reply = RawRequest(
      server_->port(),
      "GET /api/entries/20261202T100500Z-000002/x%0d%0aSet-Cookie:%20a=b?download=1 HTTP/1.1\r\n"
      "Host: x\r\nConnection: close\r\n\r\n");
  EXPECT_EQ(StatusOf(reply), 404) << reply;
  EXPECT_EQ(reply.find("Set-Cookie"), std::string::npos) << reply;
  EXPECT_EQ(reply.find("Content-Disposition"), std::string::npos) << reply;
  const std::string missing =
      RawRequest(server_->port(),
                 "GET /api/entries/20261202T100500Z-000002/no-such-file?download=1 HTTP/1.1\r\n"
                 "Host: x\r\nConnection: close\r\n\r\n");
  EXPECT_EQ(StatusOf(missing), 404) << missing;
  EXPECT_EQ(missing.find("no-such-file"), std::string::npos) << missing;
}

TEST_F(WebServerTest, TriggerIsAPostWithTheToken) {
  auto res = client_->Post("/api/trigger");
  ASSERT_TRUE(res);
  EXPECT_EQ(res->status, 401);
  EXPECT_EQ(res->get_header_value("WWW-Authenticate"), "Bearer");
  res = client_->Post("/api/trigger", {{"Authorization", "Bearer wrong-token!"}}, "", "text/plain");
  ASSERT_TRUE(res);
  EXPECT_EQ(res->status, 401);
  res = client_->Post("/api/trigger", {{"Authorization", "Bearer s3cret-tokeN"}}, "", "text/plain");
  ASSERT_TRUE(res);
  EXPECT_EQ(res->status, 401);
  res = client_->Get("/api/trigger");  // GET never changes state.
  ASSERT_TRUE(res);
  EXPECT_EQ(res->status, 404);
  EXPECT_TRUE(daemon_.requests().empty());
  res = client_->Post("/api/trigger", {{"Authorization", "Bearer s3cret-token"}}, "", "text/plain");
  ASSERT_TRUE(res);
  EXPECT_EQ(res->status, 200);
  EXPECT_EQ(json::parse(res->body)["capture"], 7);
  EXPECT_EQ(daemon_.requests(), std::vector<std::string>{"trigger"});
}

// `curl -X POST -H "Authorization: Bearer ..." URL`: no body and no Content-Length. Such a
// request has no body (RFC 9112 6.3): answered as any POST, at once, on a connection that
// stays usable.
TEST_F(WebServerTest, APostWithoutBodyOrLengthIsAnsweredLikeAnyPost) {
  const auto post = [this](const std::string& path, const std::string& auth) {
    const auto start = std::chrono::steady_clock::now();
    const std::string reply =
        RawRequest(server_->port(), "POST " + path + " HTTP/1.1\r\nHost: x\r\n" + auth +
                                        "Connection: close\r\n\r\n");
    EXPECT_LT(std::chrono::steady_clock::now() - start, 2s) << path;
    return reply;
  };
  std::string reply = post("/api/trigger", "");
  EXPECT_EQ(StatusOf(reply), 401) << reply;
  EXPECT_NE(reply.find("\"error\":\"a POST needs the token"), std::string::npos) << reply;
  reply = post("/api/trigger", "Authorization: Bearer wrong\r\n");
  EXPECT_EQ(StatusOf(reply), 401) << reply;
  EXPECT_TRUE(daemon_.requests().empty());
  reply = post("/api/trigger", "Authorization: Bearer s3cret-token\r\n");
  EXPECT_EQ(StatusOf(reply), 200) << reply;
  EXPECT_NE(reply.find("\"capture\":7"), std::string::npos) << reply;
  reply = post("/api/walk/start", "Authorization: Bearer s3cret-token\r\n");
  EXPECT_EQ(StatusOf(reply), 200) << reply;
  EXPECT_EQ(daemon_.requests(), (std::vector<std::string>{"trigger", "walk start"}));

  // Two bodiless POSTs on one keep-alive connection, then a GET: each answered in turn.
  const std::string one =
      "POST /api/trigger HTTP/1.1\r\nHost: x\r\nAuthorization: Bearer s3cret-token\r\n\r\n";
  reply =
      RawRequest(server_->port(),
                 one + one + "GET /api/entries HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n");
  size_t answers = 0;
  for (size_t at = reply.find("HTTP/1.1 200"); at != std::string::npos;
       at = reply.find("HTTP/1.1 200", at + 1)) {
    ++answers;
  }
  EXPECT_EQ(answers, 3u) << reply;
}

// Every error answer, the server's own included, is JSON with a message.
TEST_F(WebServerTest, EveryErrorAnswerIsJsonWithAMessage) {
  const auto check = [](const std::string& what, const std::string& reply, int status) {
    EXPECT_EQ(StatusOf(reply), status) << what << ": " << reply;
    const size_t body = reply.find("\r\n\r\n");
    ASSERT_NE(body, std::string::npos) << what;
    EXPECT_NE(reply.find("Content-Type: application/json"), std::string::npos) << what << reply;
    const size_t length_at = reply.find("Content-Length: ");
    ASSERT_NE(length_at, std::string::npos) << what << ": " << reply;
    const size_t length = std::stoul(reply.substr(length_at + 16));
    const json j = json::parse(reply.substr(body + 4, length), nullptr, false);
    ASSERT_TRUE(j.is_object()) << what << ": " << reply;
    ASSERT_TRUE(j.contains("error")) << what << ": " << reply;
    EXPECT_FALSE(j["error"].get<std::string>().empty()) << what;
  };
  const int port = server_->port();
  const std::string close = "Host: x\r\nConnection: close\r\n";
  check("unknown path", RawRequest(port, "GET /api/nothing HTTP/1.1\r\n" + close + "\r\n"), 404);
  check("GET of a POST", RawRequest(port, "GET /api/trigger HTTP/1.1\r\n" + close + "\r\n"), 404);
  check("POST of a GET",
        RawRequest(port, "POST /api/entries HTTP/1.1\r\n" + close + "Content-Length: 0\r\n\r\n"),
        404);
  check("unknown method", RawRequest(port, "BREW /api/entries HTTP/1.1\r\n" + close + "\r\n"), 400);
  check("no token", RawRequest(port, "POST /api/trigger HTTP/1.1\r\n" + close + "\r\n"), 401);
  check("bad chunk",
        RawRequest(port, "POST /api/trigger HTTP/1.1\r\n" + close +
                             "Transfer-Encoding: chunked\r\n\r\nzz\r\n"),
        400);
  check("body too large",
        RawRequest(port,
                   "POST /api/trigger HTTP/1.1\r\n" + close + "Content-Length: 100000000\r\n\r\n"),
        413);
  check("URI too long",
        RawRequest(port, "GET /" + std::string(10000, 'u') + " HTTP/1.1\r\n" + close + "\r\n"),
        414);
  std::string many = "GET /api/entries HTTP/1.1\r\n" + close;
  for (int i = 0; i < 200; ++i) many += "X-H" + std::to_string(i) + ": v\r\n";
  check("too many headers", RawRequest(port, many + "\r\n"), 431);
  check("no such entry",
        RawRequest(port, "GET /api/entries/20990101T000000Z-000001 HTTP/1.1\r\n" + close + "\r\n"),
        404);
  check("no such static file", RawRequest(port, "GET /missing.html HTTP/1.1\r\n" + close + "\r\n"),
        404);
  daemon_.up_ = false;
  check("daemon away", RawRequest(port, "GET /api/status HTTP/1.1\r\n" + close + "\r\n"), 503);
}

TEST_F(WebServerTest, WalkStartAndStopArePostsWithTheToken) {
  for (const char* path : {"/api/walk/start", "/api/walk/stop"}) {
    auto res = client_->Post(path);
    ASSERT_TRUE(res);
    EXPECT_EQ(res->status, 401) << path;
    res = client_->Post(path, {{"Authorization", "Bearer wrong-token!"}}, "", "text/plain");
    ASSERT_TRUE(res);
    EXPECT_EQ(res->status, 401) << path;
    res = client_->Get(path);  // GET never changes state.
    ASSERT_TRUE(res);
    EXPECT_EQ(res->status, 404) << path;
  }
  // Only the two actions: nothing else of the path reaches the daemon.
  for (const char* path : {"/api/walk/pause", "/api/walk/start%0Atrigger", "/api/walk/start/x",
                           "/api/walk/", "/api/walk"}) {
    const auto res =
        client_->Post(path, {{"Authorization", "Bearer s3cret-token"}}, "", "text/plain");
    ASSERT_TRUE(res);
    EXPECT_EQ(res->status, 404) << path;
  }
  EXPECT_TRUE(daemon_.requests().empty());
  const httplib::Headers token = {{"Authorization", "Bearer s3cret-token"}};
  auto res = client_->Post("/api/walk/start", token, "", "text/plain");
  ASSERT_TRUE(res);
  EXPECT_EQ(res->status, 200);
  EXPECT_EQ(json::parse(res->body)["walk"], 3);
  res = client_->Post("/api/walk/stop", token, "", "text/plain");
  ASSERT_TRUE(res);
  EXPECT_EQ(res->status, 200);
  EXPECT_EQ(json::parse(res->body)["keyframes"], 12);
  EXPECT_EQ(daemon_.requests(), (std::vector<std::string>{"walk start", "walk stop"}));
}

TEST_F(WebServerTest, ListsAWalksEntryWithItsFigures) {
  MakeWalkEntry(spool_, "20261202T101000Z-000003");
  const auto res = client_->Get("/api/entries");
  ASSERT_TRUE(res);
  ASSERT_EQ(res->status, 200);
  const json list = json::parse(res->body);
  ASSERT_EQ(list["entries"].size(), 3u) << res->body;
  const json& walk = list["entries"][0];
  EXPECT_EQ(walk["name"], "20261202T101000Z-000003");
  EXPECT_EQ(walk["kind"], "walk");
  EXPECT_EQ(walk["success"], true);
  EXPECT_EQ(walk["stop_reason"], "operator");
  EXPECT_EQ(walk["keyframes"], 12);
  EXPECT_EQ(walk["registered"], 11);
  EXPECT_EQ(walk["segments"], 2);
  EXPECT_EQ(walk["points"], 3456);
  EXPECT_EQ(walk["vertices"], 4567);
  EXPECT_DOUBLE_EQ(walk["walk_seconds"].get<double>(), 42.5);
  EXPECT_DOUBLE_EQ(walk["time_unix_s"].get<double>(), 1.8e9);
  EXPECT_FALSE(walk.contains("report_error")) << walk;
  EXPECT_EQ(list["entries"][1]["kind"], "pair");
  const auto map = client_->Get("/api/entries/20261202T101000Z-000003/map.glb");
  ASSERT_TRUE(map);
  EXPECT_EQ(map->status, 200);
  EXPECT_EQ(map->get_header_value("Content-Type"), "model/gltf-binary");
}

TEST_F(WebServerTest, StatusIsTheDaemonsAnswerOr503) {
  auto res = client_->Get("/api/status");
  ASSERT_TRUE(res);
  EXPECT_EQ(res->status, 200);
  EXPECT_EQ(json::parse(res->body)["state"], "idle");
  daemon_.up_ = false;
  res = client_->Get("/api/status");
  ASSERT_TRUE(res);
  EXPECT_EQ(res->status, 503);
  EXPECT_NE(json::parse(res->body)["error"].get<std::string>().find("/x"), std::string::npos);
}

TEST_F(WebServerTest, BoundsTheRequest) {
  std::string many = "GET /api/entries HTTP/1.1\r\nHost: x\r\nConnection: close\r\n";
  for (int i = 0; i < 1000; ++i) many += "X-H" + std::to_string(i) + ": v\r\n";
  EXPECT_EQ(StatusOf(RawRequest(server_->port(), many + "\r\n")), 431);
  const std::string big(1 << 20, 'b');
  const auto res = client_->Post("/api/trigger", {{"Authorization", "Bearer s3cret-token"}}, big,
                                 "application/octet-stream");
  ASSERT_TRUE(res);
  EXPECT_EQ(res->status, 413);
  EXPECT_TRUE(daemon_.requests().empty());
}

class WebServerDeadlineTest : public WebServerTest {
 protected:
  void Tune(WebServerOptions& options) override {
    options.read_timeout_s = 1;
    options.request_deadline_s = 2;
  }
};

TEST_F(WebServerDeadlineTest, ClosesARequestThatDripsPastItsDeadline) {
  // A header byte every 200 ms: each read is well within the 1 s read timeout, but the request
  // never ends. Without the deadline it would hold a worker for as long as it dripped.
  const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_port = htons(static_cast<uint16_t>(server_->port()));
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  ASSERT_EQ(::connect(fd, reinterpret_cast<const sockaddr*>(&addr), sizeof(addr)), 0);
  const std::string head = "GET /api/entries HTTP/1.1\r\nHost: x\r\nX-Drip: ";
  ASSERT_EQ(::send(fd, head.data(), head.size(), MSG_NOSIGNAL), static_cast<ssize_t>(head.size()));
  const auto start = std::chrono::steady_clock::now();
  bool closed = false;
  while (!closed && std::chrono::steady_clock::now() - start < 6s) {
    closed = ::send(fd, "a", 1, MSG_NOSIGNAL) != 1;
    pollfd p{fd, POLLIN, 0};
    char buf[512];
    if (!closed && ::poll(&p, 1, 200) > 0) closed = ::recv(fd, buf, sizeof(buf), 0) <= 0;
  }
  const double held_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  ::close(fd);
  EXPECT_TRUE(closed) << "still open after " << held_s << " s";
  EXPECT_GT(held_s, 1.8);  // Not before the 2 s deadline ...
  EXPECT_LT(held_s, 3.5);  // ... and soon after it.
  const auto res = client_->Get("/api/entries");
  ASSERT_TRUE(res);
  EXPECT_EQ(res->status, 200);
}

TEST_F(WebServerTest, EventStreamRelaysTheDaemonsEvents) {
  std::string received;
  std::mutex mutex;
  std::thread reader([&] {
    httplib::Client c("127.0.0.1", server_->port());
    c.set_read_timeout(10, 0);
    c.Get("/api/events", [&](const char* data, size_t n) {
      std::lock_guard lock(mutex);
      received.append(data, n);
      return received.find("event: entry") == std::string::npos;
    });
  });
  // The first message is the state; then the daemon's events as they come.
  for (int i = 0; i < 100; ++i) {
    {
      std::lock_guard lock(mutex);
      if (received.find("event: status") != std::string::npos) break;
    }
    std::this_thread::sleep_for(50ms);
  }
  daemon_.Emit(R"({"event":"entry","seq":5,"entry":"/s/20261202T100500Z-000002"})");
  reader.join();
  EXPECT_NE(received.find("event: status\ndata: {\"ok\":true,\"state\":\"idle\"}\n\n"),
            std::string::npos)
      << received;
  EXPECT_NE(received.find("id: 5\nevent: entry\ndata: "), std::string::npos) << received;
}

TEST(EventHub, EventMessageIsOneSseMessageOrNothing) {
  EXPECT_EQ(EventHub::EventMessage(R"({"event":"state","seq":3,"state":"idle"})"),
            "id: 3\nevent: state\ndata: {\"event\":\"state\",\"seq\":3,\"state\":\"idle\"}\n\n");
  EXPECT_EQ(EventHub::EventMessage(R"({"event":"a\nb"})"), "");
  EXPECT_EQ(EventHub::EventMessage(R"({"seq":1})"), "");
  EXPECT_EQ(EventHub::EventMessage("not json"), "");
  const std::string m = EventHub::EventMessage(R"({"event":"x","text":"line1\nline2"})");
  EXPECT_EQ(std::count(m.begin(), m.end(), '\n'), 3) << m;  // The data stays one line.
}

TEST(BearerToken, MatchesOnlyTheWholeToken) {
  EXPECT_TRUE(BearerTokenMatches("Bearer abc", "abc"));
  EXPECT_FALSE(BearerTokenMatches("Bearer abcd", "abc"));
  EXPECT_FALSE(BearerTokenMatches("Bearer ab", "abc"));
  EXPECT_FALSE(BearerTokenMatches("bearer abc", "abc"));
  EXPECT_FALSE(BearerTokenMatches("Bearer ", ""));
  EXPECT_FALSE(BearerTokenMatches("", ""));
}

}  // namespace
}  // namespace mm
