#pragma once
// A monomeshd process for integration tests: its own folder, config, control socket and spool;
// started with posix_spawn, driven over the control socket, killed on destruction.

#include <fcntl.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <optional>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "app/control.h"
#include "entry/entry.h"
#include "tests/support/read_file.h"
#include "tests/support/run_command.h"
#include "tests/support/temp_dir.h"

extern char** environ;

namespace mm::test {

namespace fs = std::filesystem;
using json = nlohmann::json;
using namespace std::chrono_literals;

inline const fs::path kData = fs::path(MM_SOURCE_DIR) / "data/tum_office";
inline const char* const kEntryFiles[] = {
    "mesh.glb",       "mesh.obj",         "mesh.mtl",   "texture.jpg",  "mesh.ply",
    "points.ply",     "cameras.txt",      "images.txt", "points3D.txt", "preview.png",
    "keyframe_b.jpg", "calibration.toml", "report.json"};

/// A camera URI other than the replay of a folder (e.g. "test:still?fps=30").
struct CameraUri {
  std::string uri;
};

/// The [control] keys after socket in every test config: the daemon's own group (a test machine
/// need not have group monomesh). Tests of the socket's access replace this line.
inline const std::string kControlAccess = "group = \"\"\n";

// `monomesh ctl watch` on a daemon's control socket, as a child process that ends at the first
// event named in `until` (or after `timeout_s`): its lines as JSON, the first one the status
// ("watching": true), then the events as they come. Closed (and waited for) on destruction.
class EventWatch {
 public:
  EventWatch(const fs::path& socket, const std::vector<std::string>& until, int timeout_s) {
    std::string command = "timeout " + std::to_string(timeout_s) + " " + Monomesh() +
                          " ctl watch --socket " + socket.string();
    for (const std::string& name : until) command += " --until " + name;
    pipe_ = ::popen(command.c_str(), "r");
  }
  EventWatch(const EventWatch&) = delete;
  EventWatch& operator=(const EventWatch&) = delete;
  ~EventWatch() { Close(); }

  /// The next line; none once the watcher has ended (or could not start).
  std::optional<json> Next() {
    char buf[65536];
    if (pipe_ == nullptr || std::fgets(buf, sizeof(buf), pipe_) == nullptr) return std::nullopt;
    return json::parse(buf);
  }
  /// Waits for the watcher to end: its wait status (0: exited 0), -1 if it never started.
  int Close() {
    if (pipe_ == nullptr) return -1;
    const int status = ::pclose(pipe_);
    pipe_ = nullptr;
    return status;
  }

 private:
  FILE* pipe_ = nullptr;
};

// A daemon process with its own folder, config, socket and spool; killed on destruction.
class DaemonProcess {
 public:
  DaemonProcess(const std::string& name, const std::string& camera_query,
                const std::string& extra_config = "", const fs::path& camera_dir = kData,
                const std::string& spool_keys = "",
                const fs::path& calibration = kData / "calib.toml")
      : DaemonProcess(name, CameraUri{"replay:" + camera_dir.string() + "?" + camera_query},
                      extra_config, spool_keys, calibration) {}

  DaemonProcess(const std::string& name, const CameraUri& camera,
                const std::string& extra_config = "", const std::string& spool_keys = "",
                const fs::path& calibration = kData / "calib.toml") {
    dir_ = TestTempPath("daemon_" + name);
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    std::ofstream(dir_ / "monomeshd.toml")
        << "[camera]\nuri = \"" << camera.uri << "\"\n"
        << "calibration = \"" << calibration.string() << "\"\n"
        << "[control]\nsocket = \"" << socket().string() << "\"\n"
        << kControlAccess << "[spool]\ndir = \"" << spool().string() << "\"\n"
        << spool_keys << extra_config;
  }
  ~DaemonProcess() { Kill(SIGKILL); }

  void Start() {
    const char* bin = std::getenv("MONOMESHD");
    ASSERT_NE(bin, nullptr) << "MONOMESHD is not set (run through ctest)";
    const std::string config = (dir_ / "monomeshd.toml").string();
    const std::string log = (dir_ / "daemon.log").string();
    posix_spawn_file_actions_t actions;
    posix_spawn_file_actions_init(&actions);
    posix_spawn_file_actions_addopen(&actions, 2, log.c_str(), O_WRONLY | O_CREAT | O_APPEND, 0644);
    std::vector<std::string> args{bin, "--config", config};
    std::vector<char*> argv;
    for (auto& a : args) argv.push_back(a.data());
    argv.push_back(nullptr);
    ASSERT_EQ(posix_spawn(&pid_, bin, &actions, nullptr, argv.data(), environ), 0);
    posix_spawn_file_actions_destroy(&actions);
    // Ready when the socket answers and the camera has delivered a frame.
    for (int i = 0; i < 400; ++i) {
      try {
        const json s = Status();
        if (s["camera"]["frames"].get<uint64_t>() > 0) return;
      } catch (const ControlError&) {
      }
      std::this_thread::sleep_for(25ms);
    }
    FAIL() << "daemon did not become ready; log:\n" << ReadFile(log);
  }

  pid_t pid() const { return pid_; }

  int Kill(int sig) {
    if (pid_ <= 0) return -1;
    ::kill(pid_, sig);
    int status = 0;
    ::waitpid(pid_, &status, 0);
    pid_ = -1;
    return status;
  }

  json Command(const std::string& c) { return json::parse(SendControlCommand(socket(), c, 5s)); }
  json Status() { return Command("status"); }

  // Triggers and waits for this capture's result.
  json TriggerAndWait(std::chrono::seconds timeout) {
    const json reply = Command("trigger");
    EXPECT_TRUE(reply.value("ok", false)) << reply.dump();
    const uint64_t id = reply.value("capture", uint64_t{0});
    const auto deadline = std::chrono::steady_clock::now() + timeout;
    while (std::chrono::steady_clock::now() < deadline) {
      const json last = Status()["last_result"];
      if (last.is_object() && last["capture"].get<uint64_t>() == id) return last;
      std::this_thread::sleep_for(50ms);
    }
    ADD_FAILURE() << "capture " << id << " did not finish; log:\n" << log();
    return json();
  }

  fs::path socket() const { return dir_ / "control.sock"; }
  fs::path spool() const { return dir_ / "spool"; }
  std::string log() const { return ReadFile(dir_ / "daemon.log"); }
  const fs::path& dir() const { return dir_; }

 private:
  fs::path dir_;
  pid_t pid_ = -1;
};

/// What a watcher sees as entries: names not starting with a dot, but the `latest` symlink.
inline std::vector<fs::path> VisibleEntries(const fs::path& spool) {
  std::vector<fs::path> out;
  for (const auto& item : fs::directory_iterator(spool)) {
    if (item.path().filename().string()[0] != '.' && !item.is_symlink()) out.push_back(item.path());
  }
  return out;
}

/// The entry's report.json through the entry library's reader (a failure to read is a test
/// failure and leaves the defaults).
inline EntryReport ReadReport(const fs::path& entry) {
  EntryReport report;
  const std::string error = ReadEntryReport(entry, &report);
  EXPECT_EQ(error, "") << entry;
  return report;
}

inline void ExpectCompleteEntry(const fs::path& entry) {
  for (const char* f : kEntryFiles) {
    EXPECT_TRUE(fs::exists(entry / f)) << entry << " lacks " << f;
  }
  EXPECT_TRUE(ReadReport(entry).success) << entry;
}

}  // namespace mm::test
