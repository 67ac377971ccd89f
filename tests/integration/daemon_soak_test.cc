// 30 s of hostile clients on the control socket while captures run: connect storms, idle
// clients, random bytes, commands split across writes. Every capture finishes, every reply is
// one line of JSON, and ping answers within 200 ms throughout.
#include <sys/socket.h>
#include <sys/un.h>

#include <algorithm>
#include <atomic>
#include <cstring>
#include <deque>
#include <mutex>
#include <random>

#include "base/unique_fd.h"
#include "tests/integration/daemon_process.h"

namespace mm::test {
namespace {

UniqueFd Connect(const fs::path& socket) {
  UniqueFd fd(::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0));
  sockaddr_un addr{};
  addr.sun_family = AF_UNIX;
  std::strncpy(addr.sun_path, socket.c_str(), sizeof(addr.sun_path) - 1);
  if (::connect(fd.get(), reinterpret_cast<sockaddr*>(&addr), sizeof(addr)) != 0) return {};
  const timeval timeout{2, 0};
  ::setsockopt(fd.get(), SOL_SOCKET, SO_RCVTIMEO, &timeout, sizeof(timeout));
  return fd;
}

// Reads to the end of the reply (the daemon closes after one line).
std::string ReadReply(int fd) {
  std::string reply;
  char buf[512];
  for (;;) {
    const ssize_t n = ::recv(fd, buf, sizeof(buf), 0);
    if (n <= 0) return reply;
    reply.append(buf, static_cast<size_t>(n));
  }
}

void Send(int fd, std::string_view bytes) {
  [[maybe_unused]] const ssize_t n = ::send(fd, bytes.data(), bytes.size(), MSG_NOSIGNAL);
}

// One line of JSON with a boolean "ok", or nothing at all when the client was refused at
// the cap or timed out: anything else is a broken reply.
bool WellFormed(const std::string& reply) {
  if (reply.empty()) return true;
  if (reply.back() != '\n' || reply.find('\n') != reply.size() - 1) return false;
  const json j = json::parse(reply, nullptr, false);
  return !j.is_discarded() && j.is_object() && j.contains("ok") && j["ok"].is_boolean();
}

TEST(DaemonSoak, HostileClientsForThirtySecondsWhileCapturing) {
  DaemonProcess daemon("soak", "rate=realtime&speed=2&loop=1", "[log]\nlevel = \"warn\"\n", kData,
                       "max_entries = 5\n");
  daemon.Start();
  std::atomic<bool> stop{false};
  std::atomic<int> storms{0}, garbage{0}, splits{0}, idles{0}, broken_replies{0}, split_errors{0};
  std::mutex ping_mutex;
  std::vector<double> ping_ms;
  int ping_failures = 0;
  const fs::path socket = daemon.socket();

  std::vector<std::thread> clients;
  struct StopAndJoin {  // Also when an assertion returns early.
    std::atomic<bool>& stop;
    std::vector<std::thread>& threads;
    ~StopAndJoin() {
      stop = true;
      for (auto& t : threads) {
        if (t.joinable()) t.join();
      }
    }
  } stop_and_join{stop, clients};
  clients.emplace_back([&] {  // Connect storm: connect and hang up at once.
    while (!stop) {
      UniqueFd fd = Connect(socket);
      ++storms;
    }
  });
  clients.emplace_back([&] {  // Idle clients: a dozen held open, one renewed every 500 ms.
    std::deque<UniqueFd> held;
    while (!stop) {
      if (held.size() >= 12) held.pop_front();
      held.push_back(Connect(socket));
      ++idles;
      std::this_thread::sleep_for(500ms);
    }
  });
  clients.emplace_back([&] {  // Random bytes, up to 600 of them, then shutdown.
    std::mt19937 rng(20261202);
    std::uniform_int_distribution<int> byte(0, 255), length(1, 600);
    while (!stop) {
      UniqueFd fd = Connect(socket);
      if (!fd.valid()) continue;
      std::string bytes(static_cast<size_t>(length(rng)), '\0');
      for (char& c : bytes) c = static_cast<char>(byte(rng));
      Send(fd.get(), bytes);
      ::shutdown(fd.get(), SHUT_WR);
      if (!WellFormed(ReadReply(fd.get()))) ++broken_replies;
      ++garbage;
    }
  });
  clients.emplace_back([&] {  // "status" in three writes.
    while (!stop) {
      UniqueFd fd = Connect(socket);
      if (!fd.valid()) continue;
      for (std::string_view piece : {"st", "atu", "s\n"}) {
        Send(fd.get(), piece);
        std::this_thread::sleep_for(10ms);
      }
      const std::string reply = ReadReply(fd.get());
      const json j = json::parse(reply, nullptr, false);
      if (j.is_discarded() || !j.value("ok", false) || !j.contains("state")) ++split_errors;
      ++splits;
    }
  });
  clients.emplace_back([&] {  // The prober: ping every 50 ms.
    while (!stop) {
      const auto start = std::chrono::steady_clock::now();
      bool ok = false;
      try {
        ok = json::parse(SendControlCommand(socket, "ping", 1s)).value("ok", false);
      } catch (const std::exception&) {
      }
      const double ms =
          std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start)
              .count();
      {
        std::lock_guard lock(ping_mutex);
        ping_ms.push_back(ms);
        if (!ok) ++ping_failures;
      }
      std::this_thread::sleep_for(50ms);
    }
  });

  // Captures, one after the other, for 30 s.
  int captures = 0, meshes = 0;
  std::vector<std::string> failures;
  const auto end = std::chrono::steady_clock::now() + 30s;
  while (std::chrono::steady_clock::now() < end) {
    const json result = daemon.TriggerAndWait(60s);
    ASSERT_TRUE(result.is_object()) << "capture " << captures + 1 << " did not finish";
    ++captures;
    if (result.value("ok", false)) {
      ++meshes;
    } else {
      failures.push_back(result.value("error", ""));
    }
  }
  stop = true;
  for (auto& t : clients) t.join();  // The figures below are read after the clients end.

  std::sort(ping_ms.begin(), ping_ms.end());
  const double ping_max = ping_ms.empty() ? 0.0 : ping_ms.back();
  const double ping_median = ping_ms.empty() ? 0.0 : ping_ms[ping_ms.size() / 2];
  std::cout << "[ figures  ] " << captures << " captures, " << meshes
            << " meshes; clients: " << storms << " storm, " << idles << " idle, " << garbage
            << " garbage, " << splits << " split; ping median " << ping_median << " ms, max "
            << ping_max << " ms over " << ping_ms.size() << "\n";
  EXPECT_GE(captures, 3);
  // The loop wraps from the last frame to the first: a capture across it loses its tracks.
  for (const std::string& f : failures) EXPECT_NE(f.find("lost track"), std::string::npos) << f;
  EXPECT_GE(meshes, captures - 2);
  EXPECT_EQ(ping_failures, 0);
  EXPECT_LE(ping_max, 200.0);
  EXPECT_EQ(broken_replies, 0);
  EXPECT_EQ(split_errors, 0);
  EXPECT_GT(storms, 100);
  EXPECT_GT(garbage, 100);
  for (const fs::path& entry : VisibleEntries(daemon.spool())) ExpectCompleteEntry(entry);
  EXPECT_EQ(WEXITSTATUS(daemon.Kill(SIGTERM)), 0);
}

}  // namespace
}  // namespace mm::test
