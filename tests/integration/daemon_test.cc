// monomeshd end to end: the bundled TUM keyframes replayed through the virtual camera, a
// trigger over the control socket, and the spool entry checked against ground truth.
#include <gtest/gtest.h>
#include <signal.h>
#include <fcntl.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <Eigen/Geometry>
#include <chrono>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <thread>

#include "app/control.h"
#include "dataset/tum.h"

extern char** environ;

namespace mm {
namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;
using namespace std::chrono_literals;

const fs::path kData = fs::path(MM_SOURCE_DIR) / "data/tum_office";
const char* const kEntryFiles[] = {"mesh.ply",    "mesh.obj",         "mesh.mtl",
                                   "texture.jpg", "calibration.toml", "report.json"};

std::string ReadAll(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

// A daemon process with its own folder, config, socket and spool; killed on destruction.
class DaemonProcess {
 public:
  DaemonProcess(const std::string& name, const std::string& camera_query,
                const std::string& extra_config = "") {
    dir_ = fs::temp_directory_path() / ("mm_daemon_" + name + "_" + std::to_string(::getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    std::ofstream(dir_ / "monomeshd.toml")
        << "[camera]\nuri = \"replay:" << kData.string() << "?" << camera_query << "\"\n"
        << "calibration = \"" << (kData / "calib.toml").string() << "\"\n"
        << "[control]\nsocket = \"" << socket().string() << "\"\n"
        << "[spool]\ndir = \"" << spool().string() << "\"\n"
        << extra_config;
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
    FAIL() << "daemon did not become ready; log:\n" << ReadAll(log);
  }

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
  std::string log() const { return ReadAll(dir_ / "daemon.log"); }
  const fs::path& dir() const { return dir_; }

 private:
  fs::path dir_;
  pid_t pid_ = -1;
};

std::vector<fs::path> VisibleEntries(const fs::path& spool) {
  std::vector<fs::path> out;
  for (const auto& item : fs::directory_iterator(spool)) {
    if (item.path().filename().string()[0] != '.') out.push_back(item.path());
  }
  return out;
}

void ExpectCompleteEntry(const fs::path& entry) {
  for (const char* f : kEntryFiles) {
    EXPECT_TRUE(fs::exists(entry / f)) << entry << " lacks " << f;
  }
  json report;
  EXPECT_NO_THROW(report = json::parse(ReadAll(entry / "report.json"))) << entry;
  EXPECT_TRUE(report.value("success", false)) << entry;
}

TEST(Daemon, TriggerProducesCompleteEntryMatchingGroundTruth) {
  DaemonProcess daemon("e2e", "rate=realtime&speed=4&loop=0");
  daemon.Start();
  const json result = daemon.TriggerAndWait(120s);
  ASSERT_TRUE(result.value("ok", false)) << result.dump() << "\n" << daemon.log();
  const fs::path entry = result["entry"].get<std::string>();
  ASSERT_EQ(entry.parent_path(), daemon.spool());
  ExpectCompleteEntry(entry);

  const json report = json::parse(ReadAll(entry / "report.json"));
  EXPECT_GT(report["counts"]["mesh_vertices"].get<int>(), 200);
  const std::string ply = ReadAll(entry / "mesh.ply");
  const auto pos = ply.find("element vertex ");
  ASSERT_NE(pos, std::string::npos);
  EXPECT_GT(std::stoi(ply.substr(pos + 15)), 200);

  // Relative rotation within 2 degrees of the motion-capture ground truth of the two frames.
  const Trajectory gt = Trajectory::Read(kData / "groundtruth.txt");
  const auto pose_a = gt.WorldFromCamAt(report["keyframes"]["a"]["source_time_s"].get<double>());
  const auto pose_b = gt.WorldFromCamAt(report["keyframes"]["b"]["source_time_s"].get<double>());
  ASSERT_TRUE(pose_a && pose_b);
  Eigen::Matrix3d r;
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) r(i, j) = report["relative_pose"]["rotation"][i][j].get<double>();
  }
  const double err = RotationErrorDeg(r, CamBFromCamA(*pose_a, *pose_b).linear());
  EXPECT_LT(err, 2.0);
  std::cout << "[ figures  ] pair " << report["keyframes"]["a"]["source"] << " -> "
            << report["keyframes"]["b"]["source"] << ": rotation error " << err << " deg, "
            << report["counts"]["mesh_vertices"] << " vertices\n";

  EXPECT_EQ(daemon.Command("trigger").value("ok", true), true);  // Idle again: accepted.
  EXPECT_FALSE(daemon.Command("trigger").value("ok", true));     // Tracking: refused as busy.
  EXPECT_FALSE(daemon.Command("bogus").value("ok", true));
  EXPECT_EQ(WEXITSTATUS(daemon.Kill(SIGTERM)), 0);
}

// kill -9 while the daemon writes an entry: nothing half-written is ever visible, and the
// restarted daemon removes the leftovers.
TEST(Daemon, KillDuringSpoolWriteLeavesNoPartialEntry) {
  DaemonProcess daemon("kill", "rate=realtime&speed=8&loop=1");
  daemon.Start();
  bool killed_mid_write = false;
  for (int attempt = 0; attempt < 10 && !killed_mid_write; ++attempt) {
    const json reply = daemon.Command("trigger");
    if (!reply.value("ok", false)) {
      std::this_thread::sleep_for(100ms);
      continue;
    }
    const uint64_t id = reply["capture"].get<uint64_t>();
    const auto deadline = std::chrono::steady_clock::now() + 60s;
    while (std::chrono::steady_clock::now() < deadline) {
      bool temp_seen = false;
      for (const auto& item : fs::directory_iterator(daemon.spool())) {
        temp_seen = temp_seen || item.path().filename().string().rfind(".tmp-", 0) == 0;
      }
      if (temp_seen) {
        daemon.Kill(SIGKILL);
        killed_mid_write = true;
        break;
      }
      const json last = daemon.Status()["last_result"];
      if (last.is_object() && last["capture"].get<uint64_t>() == id) break;  // Missed it.
    }
  }
  ASSERT_TRUE(killed_mid_write) << "never caught the daemon writing; log:\n" << daemon.log();
  for (const fs::path& entry : VisibleEntries(daemon.spool())) ExpectCompleteEntry(entry);

  daemon.Start();  // Same config and spool: recovery removes the leftovers.
  for (const auto& item : fs::directory_iterator(daemon.spool())) {
    EXPECT_NE(item.path().filename().string().rfind(".tmp-", 0), 0u) << item.path();
  }
  EXPECT_NE(daemon.log().find("incomplete entries left by an earlier crash"), std::string::npos);
}

int RunDaemonExpectingExit(const fs::path& config, std::string* log) {
  const char* bin = std::getenv("MONOMESHD");
  const std::string cmd = std::string(bin) + " --config " + config.string() + " 2>&1";
  FILE* pipe = ::popen(cmd.c_str(), "r");
  char buf[512];
  while (std::fgets(buf, sizeof(buf), pipe) != nullptr) *log += buf;
  const int status = ::pclose(pipe);
  return WEXITSTATUS(status);
}

TEST(Daemon, BadConfigExits78NamingTheKey) {
  DaemonProcess daemon("badconfig", "rate=max", "[keyframes]\nparallax_deg = -3\n");
  std::string log;
  EXPECT_EQ(RunDaemonExpectingExit(daemon.dir() / "monomeshd.toml", &log), 78);
  EXPECT_NE(log.find("keyframes.parallax_deg"), std::string::npos) << log;
}

TEST(Daemon, BrokenCalibrationExits78NamingTheFile) {
  DaemonProcess daemon("badcalib", "rate=max");
  const fs::path calib = daemon.dir() / "broken.toml";
  std::ofstream(calib) << "[camera]\nimage_size = [640, 480]\nfc = [500]\ncc = [1, 2]\nkc = [0,0,0,0]\n";
  std::ofstream(daemon.dir() / "monomeshd.toml", std::ios::app);
  std::string text = ReadAll(daemon.dir() / "monomeshd.toml");
  text.replace(text.find((kData / "calib.toml").string()), (kData / "calib.toml").string().size(),
               calib.string());
  std::ofstream(daemon.dir() / "monomeshd.toml") << text;
  std::string log;
  EXPECT_EQ(RunDaemonExpectingExit(daemon.dir() / "monomeshd.toml", &log), 78);
  EXPECT_NE(log.find("broken.toml"), std::string::npos) << log;
  EXPECT_NE(log.find("camera.fc"), std::string::npos) << log;
}

TEST(Daemon, MissingCameraFolderIsReportedWithThePath) {
  DaemonProcess daemon("nocamera", "rate=max");
  std::string text = ReadAll(daemon.dir() / "monomeshd.toml");
  text.replace(text.find("replay:") + 7, kData.string().size(), "/nonexistent/cam");
  std::ofstream(daemon.dir() / "monomeshd.toml") << text;
  std::string log;
  EXPECT_NE(RunDaemonExpectingExit(daemon.dir() / "monomeshd.toml", &log), 0);
  EXPECT_NE(log.find("/nonexistent/cam"), std::string::npos) << log;
}

}  // namespace
}  // namespace mm
