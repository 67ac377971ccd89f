// monomeshd end to end: the bundled TUM keyframes replayed through the virtual camera, a
// trigger over the control socket, and the spool entry checked against ground truth.
#include <grp.h>
#include <poll.h>
#include <sys/mount.h>
#include <sys/resource.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/statvfs.h>
#include <sys/un.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cstdio>
#include <cstring>
#include <iterator>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "base/unique_fd.h"
#include "dataset/tum.h"
#include "tests/integration/daemon_process.h"
#include "tests/support/rotation_sequence.h"
#include "tests/support/run_command.h"

namespace mm::test {
namespace {

TEST(Daemon, TriggerProducesCompleteEntryMatchingGroundTruth) {
  // The keyframes are 1 s apart: at their own pace even a sanitizer build's gate (~0.5 s per
  // frame under ASan) tracks every one, so the pair is the one a board would take.
  DaemonProcess daemon("e2e", "rate=realtime&loop=0");
  daemon.Start();
  const json result = daemon.TriggerAndWait(120s);
  ASSERT_TRUE(result.value("ok", false)) << result.dump() << "\n" << daemon.log();
  const fs::path entry = result["entry"].get<std::string>();
  ASSERT_EQ(entry.parent_path(), daemon.spool());
  ExpectCompleteEntry(entry);
  // `latest` names the entry; watchers skip it (a symlink), so the spool shows one entry.
  EXPECT_EQ(fs::read_symlink(daemon.spool() / "latest"), entry.filename());
  EXPECT_EQ(VisibleEntries(daemon.spool()).size(), 1u);
  // The control socket: group and owner read and write, nobody else (the default mode 0660).
  struct stat sock {};
  ASSERT_EQ(::lstat(daemon.socket().c_str(), &sock), 0);
  EXPECT_TRUE(S_ISSOCK(sock.st_mode));
  EXPECT_EQ(sock.st_mode & 07777, 0660u) << std::oct << (sock.st_mode & 07777);

  const EntryReport report = ReadReport(entry);
  // Wall-clock capture times beside the monotonic ones, of this boot.
  const int64_t now_ns = std::chrono::duration_cast<std::chrono::nanoseconds>(
                             std::chrono::system_clock::now().time_since_epoch())
                             .count();
  for (const KeyframeInfo* k : {&report.keyframe_a, &report.keyframe_b}) {
    EXPECT_GT(k->capture_time_ns, 0);
    EXPECT_LE(k->capture_realtime_ns, now_ns);
    EXPECT_GT(k->capture_realtime_ns, now_ns - int64_t{300'000'000'000});  // Within 5 min.
  }
  // The same clock offset for both (up to the jitter of reading the two clocks).
  EXPECT_NEAR(
      static_cast<double>(report.keyframe_b.capture_realtime_ns -
                          report.keyframe_a.capture_realtime_ns),
      static_cast<double>(report.keyframe_b.capture_time_ns - report.keyframe_a.capture_time_ns),
      1e6);
  EXPECT_EQ(report.boot_id, ReadFile("/proc/sys/kernel/random/boot_id").substr(0, 36));
  EXPECT_EQ(report.schema_version, kEntryReportSchemaVersion);
  EXPECT_GT(report.counts.mesh_vertices, 200u);
  const std::string ply = ReadFile(entry / "mesh.ply");
  const auto pos = ply.find("element vertex ");
  ASSERT_NE(pos, std::string::npos);
  EXPECT_GT(std::stoi(ply.substr(pos + 15)), 200);

  // Relative rotation within 2 degrees of the motion-capture ground truth of the two frames.
  const Trajectory gt = Trajectory::Read(kData / "groundtruth.txt");
  const auto pose_a = gt.WorldFromCamAt(report.keyframe_a.source_time_s);
  const auto pose_b = gt.WorldFromCamAt(report.keyframe_b.source_time_s);
  ASSERT_TRUE(pose_a && pose_b);
  const Eigen::Matrix3d& r = report.relative_pose.rotation;
  const double err = RotationErrorDeg(r, CamBFromCamA(*pose_a, *pose_b).linear());
  EXPECT_LT(err, 2.0);
  std::cout << "[ figures  ] pair \"" << report.keyframe_a.source << "\" -> \""
            << report.keyframe_b.source << "\": rotation error " << err << " deg, "
            << report.counts.mesh_vertices << " vertices\n";

  EXPECT_EQ(daemon.Status()["last_trigger"], "control socket");
  // SIGUSR1 is a trigger too (the same path as the socket and the GPIO button).
  const uint64_t captures = daemon.Status()["captures"].get<uint64_t>();
  ::kill(daemon.pid(), SIGUSR1);
  json status;
  for (int i = 0; i < 100; ++i) {
    status = daemon.Status();
    if (status["captures"].get<uint64_t>() > captures) break;
    std::this_thread::sleep_for(50ms);
  }
  EXPECT_EQ(status["captures"].get<uint64_t>(), captures + 1) << status.dump();
  EXPECT_EQ(status["last_trigger"], "SIGUSR1");
  EXPECT_NE(status["state"], "idle");
  EXPECT_FALSE(daemon.Command("trigger").value("ok", true));  // Tracking: refused as busy.
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

// SIGTERM while the pair is reconstructed: the accepted capture is finished (an entry, whole)
// and logged before the clean exit; SIGTERM while tracking logs the capture as abandoned.
TEST(Daemon, SigtermFinishesTheReconstructionOrLogsTheCaptureAbandoned) {
  DaemonProcess daemon("sigterm", "rate=realtime&speed=2&loop=1");
  daemon.Start();
  bool stopped_while_reconstructing = false;
  for (int attempt = 0; attempt < 10 && !stopped_while_reconstructing; ++attempt) {
    const json reply = daemon.Command("trigger");
    ASSERT_TRUE(reply.value("ok", false)) << reply.dump();
    const uint64_t id = reply["capture"].get<uint64_t>();
    const auto deadline = std::chrono::steady_clock::now() + 60s;
    while (std::chrono::steady_clock::now() < deadline) {
      const json status = daemon.Status();
      if (status["state"] == "reconstructing") {
        const int wait_status = daemon.Kill(SIGTERM);
        ASSERT_TRUE(WIFEXITED(wait_status)) << wait_status << "; log:\n" << daemon.log();
        EXPECT_EQ(WEXITSTATUS(wait_status), 0) << daemon.log();
        stopped_while_reconstructing = true;
        const std::string log = daemon.log();
        const std::string capture = "capture " + std::to_string(id);
        const size_t stopping = log.find("stopping: " + capture + " is being reconstructed");
        ASSERT_NE(stopping, std::string::npos) << log;
        // Its result, whichever it is, is logged after that: a mesh, or why it has none.
        EXPECT_TRUE(log.find(capture + ": ", stopping) != std::string::npos ||
                    log.find(capture + " abandoned: keyframe B refused", stopping) !=
                        std::string::npos)
            << log;
        break;
      }
      const json last = status["last_result"];
      if (last.is_object() && last["capture"].get<uint64_t>() == id) break;  // Missed it.
      std::this_thread::sleep_for(5ms);
    }
  }
  ASSERT_TRUE(stopped_while_reconstructing) << "never caught a reconstruction; log:\n"
                                            << daemon.log();
  for (const fs::path& entry : VisibleEntries(daemon.spool())) ExpectCompleteEntry(entry);

  DaemonProcess tracking("sigterm_tracking", "rate=realtime&loop=1");
  tracking.Start();
  const json reply = tracking.Command("trigger");
  ASSERT_TRUE(reply.value("ok", false)) << reply.dump();
  const int wait_status = tracking.Kill(SIGTERM);
  ASSERT_TRUE(WIFEXITED(wait_status)) << wait_status << "; log:\n" << tracking.log();
  EXPECT_EQ(WEXITSTATUS(wait_status), 0) << tracking.log();
  EXPECT_NE(tracking.log().find("capture " + std::to_string(reply["capture"].get<uint64_t>()) +
                                " abandoned: stopped while tracking"),
            std::string::npos)
      << tracking.log();
}

// The daemon's exit code; a daemon still running after 60 s is stopped (timeout exits 124).
int RunDaemonExpectingExit(const fs::path& config, std::string* log) {
  const char* bin = std::getenv("MONOMESHD");
  const std::string cmd =
      "timeout -k 5 60 " + std::string(bin) + " --config " + config.string() + " 2>&1";
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

// The gate may not take a B the reconstruction would refuse: its target below [recon]
// min_parallax_deg is a config error naming the key.
TEST(Daemon, GateTargetBelowTheReconstructionsMinimumExits78) {
  DaemonProcess daemon("gatebelow", "rate=max", "[keyframes]\nparallax_deg = 0.5\n");
  std::string log;
  EXPECT_EQ(RunDaemonExpectingExit(daemon.dir() / "monomeshd.toml", &log), 78);
  EXPECT_NE(log.find("keyframes.parallax_deg"), std::string::npos) << log;
  EXPECT_NE(log.find("refused"), std::string::npos) << log;
}

TEST(Daemon, BrokenCalibrationExits78NamingTheFile) {
  DaemonProcess daemon("badcalib", "rate=max");
  const fs::path calib = daemon.dir() / "broken.toml";
  std::ofstream(calib)
      << "[camera]\nimage_size = [640, 480]\nfc = [500]\ncc = [1, 2]\nkc = [0,0,0,0]\n";
  std::ofstream(daemon.dir() / "monomeshd.toml", std::ios::app);
  std::string text = ReadFile(daemon.dir() / "monomeshd.toml");
  text.replace(text.find((kData / "calib.toml").string()), (kData / "calib.toml").string().size(),
               calib.string());
  std::ofstream(daemon.dir() / "monomeshd.toml") << text;
  std::string log;
  EXPECT_EQ(RunDaemonExpectingExit(daemon.dir() / "monomeshd.toml", &log), 78);
  EXPECT_NE(log.find("broken.toml"), std::string::npos) << log;
  EXPECT_NE(log.find("camera.fc"), std::string::npos) << log;
}

// Files the daemon reads whole are regular files of bounded size: a calibration that is a
// device that never ends (/dev/zero), or a config that is a FIFO nobody writes, is refused at
// once (78, naming the path) instead of filling memory or waiting forever.
TEST(Daemon, CalibrationOrConfigThatIsNotARegularFileExits78AtOnce) {
  DaemonProcess device("devcalib", CameraUri{"replay:" + kData.string() + "?rate=max"}, "", "",
                       "/dev/zero");
  std::string log;
  EXPECT_EQ(RunDaemonExpectingExit(device.dir() / "monomeshd.toml", &log), 78) << log;
  EXPECT_NE(log.find("/dev/zero: not a regular file"), std::string::npos) << log;

  const fs::path fifo = device.dir() / "fifo.toml";
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  log.clear();
  EXPECT_EQ(RunDaemonExpectingExit(fifo, &log), 78) << log;
  EXPECT_NE(log.find(fifo.string() + ": not a regular file"), std::string::npos) << log;
}

// A copy of the bundled dataset the test may change.
fs::path CopyOfBundledData(const std::string& name) {
  const fs::path dir = TestTempPath("data_" + name);
  fs::remove_all(dir);
  fs::copy(kData, dir, fs::copy_options::recursive);
  return dir;
}

// A calibration's image size above kMaxImageSide is refused at load, naming the file and the
// field (OpenCV's cv::Exception from the undistortion maps aborted the daemon: SIGABRT, which
// systemd restarts forever).
TEST(Daemon, HugeCalibrationImageSizeExits78NamingTheField) {
  const fs::path calib =
      fs::temp_directory_path() / ("mm_huge_calib_" + std::to_string(::getpid()) + ".toml");
  RemovedWhenAllPass::Add(calib);
  std::ofstream(calib) << "[camera]\nimage_size = [1000000, 1000000]\nfc = [500, 500]\n"
                          "cc = [320, 240]\nkc = [0, 0, 0, 0]\n";
  DaemonProcess daemon("hugecalib", "rate=max", "", kData, "", calib);
  std::string log;
  EXPECT_EQ(RunDaemonExpectingExit(daemon.dir() / "monomeshd.toml", &log), 78) << log;
  EXPECT_NE(log.find(calib.string()), std::string::npos) << log;
  EXPECT_NE(log.find("camera.image_size"), std::string::npos) << log;
  fs::remove(calib);
}

// Something at the configured socket path that is not a socket is never deleted: the daemon
// exits 78 (a config error) naming the path, and the file or folder is as it was.
TEST(Daemon, SocketPathHoldingAFileOrFolderIsLeftAloneAndExits78) {
  DaemonProcess daemon("sockfile", "rate=max");
  std::ofstream(daemon.socket()) << "precious";
  std::string log;
  EXPECT_EQ(RunDaemonExpectingExit(daemon.dir() / "monomeshd.toml", &log), 78) << log;
  EXPECT_NE(log.find(daemon.socket().string() + ": exists and is not a socket"), std::string::npos)
      << log;
  EXPECT_EQ(ReadFile(daemon.socket()), "precious");
  fs::remove(daemon.socket());
  fs::create_directories(daemon.socket() / "inside");
  log.clear();
  EXPECT_EQ(RunDaemonExpectingExit(daemon.dir() / "monomeshd.toml", &log), 78) << log;
  EXPECT_TRUE(fs::is_directory(daemon.socket() / "inside"));
}

// A file where the spool folder (or a parent of it) must be: restarting cannot help, so the
// exit is 78, naming the path, and the file stays as it was.
TEST(Daemon, SpoolPathHoldingAFileExits78AndLeavesItAlone) {
  DaemonProcess daemon("spoolfile", "rate=max");
  std::ofstream(daemon.spool()) << "precious";
  std::string log;
  EXPECT_EQ(RunDaemonExpectingExit(daemon.dir() / "monomeshd.toml", &log), 78) << log;
  EXPECT_NE(log.find("spool " + daemon.spool().string() + ": cannot create"), std::string::npos)
      << log;
  EXPECT_EQ(ReadFile(daemon.spool()), "precious");
}

// [control] group and mode apply to the socket file before the daemon listens; a group that
// does not exist is a config error naming the key (exit 78), and nothing is left at the path.
TEST(Daemon, ControlSocketGroupAndModeAreApplied) {
  DaemonProcess daemon("sockmode", "rate=max&loop=1");
  const std::string config = ReadFile(daemon.dir() / "monomeshd.toml");
  auto with_access = [&](const std::string& access) {
    std::string text = config;
    text.replace(text.find(kControlAccess), kControlAccess.size(), access);
    std::ofstream(daemon.dir() / "monomeshd.toml") << text;
  };
  const group* own = ::getgrgid(::getegid());
  ASSERT_NE(own, nullptr);
  with_access("group = \"" + std::string(own->gr_name) + "\"\nmode = 0o640\n");
  daemon.Start();
  struct stat sock {};
  ASSERT_EQ(::lstat(daemon.socket().c_str(), &sock), 0);
  EXPECT_EQ(sock.st_mode & 07777, 0640u) << std::oct << (sock.st_mode & 07777);
  EXPECT_EQ(sock.st_gid, own->gr_gid);
  EXPECT_EQ(WEXITSTATUS(daemon.Kill(SIGTERM)), 0);

  with_access("group = \"mm-no-such-group\"\n");
  std::string log;
  EXPECT_EQ(RunDaemonExpectingExit(daemon.dir() / "monomeshd.toml", &log), 78) << log;
  EXPECT_NE(log.find("control.group"), std::string::npos) << log;
  EXPECT_NE(log.find("mm-no-such-group"), std::string::npos) << log;
  EXPECT_FALSE(fs::exists(fs::symlink_status(daemon.socket())));
}

// Bytes that are not UTF-8 on the control socket: the reply echoes the command with U+FFFD and
// is valid JSON; the daemon keeps serving (nlohmann's dump() threw, the daemon exited 70).
TEST(Daemon, InvalidUtf8CommandIsAnsweredAndTheDaemonKeepsServing) {
  DaemonProcess daemon("utf8cmd", "rate=realtime&loop=1");
  daemon.Start();
  for (const std::string command : {"\xff",
                                    "st\xc3"
                                    "atus",
                                    "\xed\xa0\x80"}) {
    std::string line;
    ASSERT_NO_THROW(line = SendControlCommand(daemon.socket(), command, 5s)) << daemon.log();
    json reply;
    ASSERT_NO_THROW(reply = json::parse(line)) << line;
    EXPECT_FALSE(reply.value("ok", true)) << line;
    EXPECT_NE(reply.value("error", "").find("\xef\xbf\xbd"), std::string::npos) << line;
  }
  EXPECT_TRUE(daemon.Command("ping").value("ok", false));
  EXPECT_EQ(daemon.Status()["state"], "idle");
  EXPECT_EQ(WEXITSTATUS(daemon.Kill(SIGTERM)), 0);
}

// Frame file names that are not UTF-8 (any byte string is a Linux file name) reach status (the
// camera's last error, the keyframe's source) and report.json: both stay valid JSON, and the
// capture's entry is written.
TEST(Daemon, NonUtf8FrameFileNamesKeepStatusAndReportsWorking) {
  const fs::path data = CopyOfBundledData("utf8names");
  std::ifstream list_in(data / "rgb.txt");
  std::ostringstream list_out;
  for (std::string line; std::getline(list_in, line);) {
    const auto slash = line.find("rgb/");
    if (line.empty() || line[0] == '#' || slash == std::string::npos) {
      list_out << line << "\n";
      continue;
    }
    const std::string file = line.substr(slash);
    const std::string renamed = "rgb/\xff\xfe" + file.substr(4);
    fs::rename(data / file, data / renamed);
    list_out << line.substr(0, slash) << renamed << "\n";
  }
  list_in.close();
  std::ofstream(data / "rgb.txt") << list_out.str();
  DaemonProcess daemon("utf8names", "rate=realtime&speed=2&loop=0", "", data);
  daemon.Start();
  const json result = daemon.TriggerAndWait(120s);
  ASSERT_TRUE(result.value("ok", false)) << result.dump() << "\n" << daemon.log();
  const fs::path entry = result["entry"].get<std::string>();
  ExpectCompleteEntry(entry);
  EXPECT_NE(ReadReport(entry).keyframe_a.source.find("\xef\xbf\xbd"), std::string::npos);
  EXPECT_TRUE(daemon.Command("ping").value("ok", false));
  EXPECT_EQ(WEXITSTATUS(daemon.Kill(SIGTERM)), 0);
}

// A raw control-socket connection (the tests below write in pieces and hold connections).
UniqueFd ConnectRaw(const fs::path& socket) {
  UniqueFd fd(::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0));
  sockaddr_un addr{};
  addr.sun_family = AF_UNIX;
  std::strncpy(addr.sun_path, socket.c_str(), sizeof(addr.sun_path) - 1);
  if (::connect(fd.get(), reinterpret_cast<const sockaddr*>(&addr), sizeof(addr)) != 0) {
    return UniqueFd();
  }
  return fd;
}

void SendRaw(int fd, const std::string& bytes) {
  ASSERT_EQ(::send(fd, bytes.data(), bytes.size(), MSG_NOSIGNAL),
            static_cast<ssize_t>(bytes.size()));
}

// What the daemon sends until it closes the connection or `timeout` passes; *closed says which.
std::string ReadUntilClosed(int fd, std::chrono::milliseconds timeout, bool* closed) {
  std::string got;
  *closed = false;
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  char buf[4096];
  while (std::chrono::steady_clock::now() < deadline) {
    pollfd p{fd, POLLIN, 0};
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(
        deadline - std::chrono::steady_clock::now());
    if (::poll(&p, 1, static_cast<int>(std::max<int64_t>(left.count(), 1))) <= 0) continue;
    const ssize_t n = ::recv(fd, buf, sizeof(buf), 0);
    if (n <= 0) {
      *closed = true;
      break;
    }
    got.append(buf, static_cast<size_t>(n));
  }
  return got;
}

// The control protocol per client: a command split across writes is one command; a request
// without an end of line is bounded in length and in time.
TEST(Daemon, ControlRequestsAreLineBufferedBoundedAndTimedOut) {
  DaemonProcess daemon("ctlproto", "rate=realtime&loop=1");
  daemon.Start();
  {
    UniqueFd c = ConnectRaw(daemon.socket());
    ASSERT_TRUE(c.valid());
    SendRaw(c.get(), "sta");
    std::this_thread::sleep_for(200ms);
    SendRaw(c.get(), "tus\n");
    bool closed = false;
    const std::string reply = ReadUntilClosed(c.get(), 5s, &closed);
    EXPECT_TRUE(closed);
    const json j = json::parse(reply, nullptr, false);
    EXPECT_TRUE(j.value("ok", false)) << reply;
    EXPECT_EQ(j.value("state", ""), "idle") << reply;
  }
  {
    UniqueFd c = ConnectRaw(daemon.socket());
    ASSERT_TRUE(c.valid());
    SendRaw(c.get(), std::string(4096, 'x'));
    bool closed = false;
    const std::string reply = ReadUntilClosed(c.get(), 5s, &closed);
    EXPECT_TRUE(closed);
    EXPECT_NE(reply.find("longer than"), std::string::npos) << reply;
  }
  {
    // An idle client is closed after the idle timeout (5 s), one with half a line too.
    UniqueFd idle = ConnectRaw(daemon.socket());
    UniqueFd half = ConnectRaw(daemon.socket());
    ASSERT_TRUE(idle.valid() && half.valid());
    SendRaw(half.get(), "pi");
    bool closed = false;
    ReadUntilClosed(idle.get(), 8s, &closed);
    EXPECT_TRUE(closed) << "an idle client was held beyond the timeout";
    const std::string reply = ReadUntilClosed(half.get(), 2s, &closed);
    EXPECT_TRUE(closed);
    EXPECT_NE(reply.find("no end of line"), std::string::npos) << reply;
  }
  EXPECT_TRUE(daemon.Command("ping").value("ok", false));
  EXPECT_EQ(WEXITSTATUS(daemon.Kill(SIGTERM)), 0);
}

// More clients than the cap are answered "busy" and closed; the held ones time out and the
// daemon serves again.
// The robot's odometry over the control socket scales the entry. A bridge streams the ground
// truth's camera centres on one connection (dataset time: [scale] odometry_clock = "camera",
// the replay camera's clock); the entry is in metres, its baseline the ground truth's between the
// keyframes. With no odometry the entry stays up to scale and says why.
// `monomesh ctl watch`: one JSON line per event, numbered without gaps, in the order the capture
// went through them (gate progress lines may come between any two while tracking).
TEST(Daemon, WatchStreamsTheEventsOfACaptureInOrder) {
  ASSERT_FALSE(Monomesh().empty()) << "MONOMESH is not set (run through ctest)";
  DaemonProcess daemon("watch", "rate=realtime&loop=1");
  daemon.Start();
  EventWatch watch(daemon.socket(), {"entry", "capture_failed"}, 120);
  std::vector<json> lines;
  std::optional<json> first = watch.Next();
  ASSERT_TRUE(first) << daemon.log();
  lines.push_back(*first);
  ASSERT_TRUE(lines[0].value("watching", false)) << lines[0].dump();
  EXPECT_EQ(lines[0]["status"]["state"], "idle");
  const json reply = daemon.Command("trigger");
  ASSERT_TRUE(reply.value("ok", false)) << reply.dump();
  while (std::optional<json> e = watch.Next()) lines.push_back(*e);
  const int status = watch.Close();
  ASSERT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << status << "\n" << daemon.log();

  std::string sequence;  // The events' names (a state change as its state), gate lines left out.
  int gate_lines = 0;
  uint64_t seq = lines[0]["seq"].get<uint64_t>();
  int64_t time_ns = 0;
  for (size_t i = 1; i < lines.size(); ++i) {
    const json& e = lines[i];
    EXPECT_EQ(e["seq"].get<uint64_t>(), ++seq) << e.dump();
    EXPECT_GE(e["time_ns"].get<int64_t>(), time_ns) << e.dump();
    time_ns = e["time_ns"].get<int64_t>();
    EXPECT_EQ(e["capture"], reply["capture"]) << e.dump();
    const std::string name = e["event"];
    if (name == "gate") {
      ++gate_lines;
      EXPECT_GE(e["parallax_deg"].get<double>(), 0.0);
      continue;
    }
    sequence += (name == "state" ? e["state"].get<std::string>() : name) + " ";
  }
  std::cout << "[ figures  ] events: " << sequence << "(" << gate_lines << " gate lines)\n";
  // B refused and tracking on repeats the middle; the capture ends with its entry.
  std::string_view rest = sequence;
  const auto take = [&rest](std::string_view part) {
    if (!rest.starts_with(part)) return false;
    rest.remove_prefix(part.size());
    return true;
  };
  bool in_order = take("keyframe_a tracking ");
  while (in_order && take("keyframe_b reconstructing keyframe_b_refused tracking ")) {
  }
  in_order = in_order && take("keyframe_b reconstructing entry ") && rest.empty();
  EXPECT_TRUE(in_order) << sequence << "\n" << daemon.log();
  ASSERT_EQ(lines.back()["event"], "entry");
  ExpectCompleteEntry(lines.back()["entry"].get<std::string>());
}

// [hooks]: on_entry runs with each entry's folder; one that hangs is killed at its limit and
// logged, and the next capture goes on meanwhile; on_failure gets the reason and its exit
// status is logged.
TEST(Daemon, HooksRunAfterCapturesAndOneThatHangsNeverDelaysTheNext) {
  const auto write_script = [](const fs::path& path, const std::string& body) {
    std::ofstream(path) << "#!/bin/sh\n" << body;
    fs::permissions(path, fs::perms::owner_all);
  };
  DaemonProcess daemon("hooks", "rate=realtime&loop=1",
                       "[hooks]\non_entry = \"hook.sh\"\ntimeout_s = 1.0\n");
  write_script(daemon.dir() / "hook.sh",
               "echo \"$1\" >> " + (daemon.dir() / "entries.txt").string() + "\nsleep 60\n");
  daemon.Start();
  std::vector<std::string> entries;
  for (int i = 0; i < 2; ++i) {
    const json result = daemon.TriggerAndWait(120s);
    ASSERT_TRUE(result.value("ok", false)) << result.dump() << "\n" << daemon.log();
    entries.push_back(result["entry"].get<std::string>());
  }
  // Each hook hangs for 60 s: the second capture finished while the first hook still hung or
  // had been killed, never waiting for it.
  const auto deadline = std::chrono::steady_clock::now() + 10s;
  while (std::chrono::steady_clock::now() < deadline &&
         daemon.log().find("hook on_entry (pid") == std::string::npos) {
    std::this_thread::sleep_for(100ms);
  }
  const std::string log = daemon.log();
  EXPECT_NE(log.find("killed at its 1 s limit (killed by signal 9"), std::string::npos) << log;
  // The second entry's hook starts once its entry is committed, which the trigger's reply
  // can precede: wait (bounded) until both hooks have written their line.
  const auto recorded_all = [&] {
    const std::string text = ReadFile(daemon.dir() / "entries.txt");
    return std::all_of(entries.begin(), entries.end(), [&](const std::string& entry) {
      return text.find(entry + "\n") != std::string::npos;
    });
  };
  const auto hooks_deadline = std::chrono::steady_clock::now() + 10s;
  while (std::chrono::steady_clock::now() < hooks_deadline && !recorded_all()) {
    std::this_thread::sleep_for(100ms);
  }
  std::string recorded = ReadFile(daemon.dir() / "entries.txt");
  for (const std::string& entry : entries) {
    EXPECT_NE(recorded.find(entry + "\n"), std::string::npos) << recorded;
  }

  DaemonProcess failing("hooks_failure", "rate=realtime&loop=1",
                        "[keyframes]\ntimeout_s = 0.05\n[hooks]\non_failure = \"fail.sh\"\n");
  write_script(failing.dir() / "fail.sh",
               "echo \"$1\" > " + (failing.dir() / "reason.txt").string() + "\nexit 3\n");
  failing.Start();
  const json result = failing.TriggerAndWait(60s);
  ASSERT_FALSE(result.value("ok", true)) << result.dump();
  const auto failed_by = std::chrono::steady_clock::now() + 10s;
  while (std::chrono::steady_clock::now() < failed_by &&
         failing.log().find("hook on_failure (pid") == std::string::npos) {
    std::this_thread::sleep_for(100ms);
  }
  EXPECT_NE(failing.log().find("failed: exited 3"), std::string::npos) << failing.log();
  EXPECT_EQ(ReadFile(failing.dir() / "reason.txt"), result["error"].get<std::string>() + "\n");
}

TEST(Daemon, OdometryStreamedOnTheControlSocketScalesTheEntry) {
  const std::string scale_keys = "[scale]\nsource = \"odometry\"\nodometry_clock = \"camera\"\n";
  DaemonProcess daemon("odom", "rate=realtime&loop=0", scale_keys);
  daemon.Start();
  const Trajectory truth = Trajectory::Read(kData / "groundtruth.txt");
  UniqueFd bridge = ConnectRaw(daemon.socket());
  ASSERT_TRUE(bridge.valid());
  std::string lines;
  for (const TimedPose& pose : truth.poses()) {
    const Eigen::Vector3d c = pose.world_from_cam.translation();
    char line[128];
    std::snprintf(line, sizeof(line), "odom %.4f %.6f %.6f %.6f\n", pose.timestamp_s, c.x(), c.y(),
                  c.z());
    lines += line;
  }
  lines += "odom 1 2 nan 4\n";  // A bad line is answered, and the stream goes on.
  // Written while the answers are read, as a bridge that reads them does (the answers of one
  // that does not are dropped once its socket buffer is full).
  std::thread writer([&] { SendRaw(bridge.get(), lines); });
  struct Join {
    std::thread& t;
    ~Join() { t.join(); }
  } join{writer};
  std::string replies;
  const size_t expected = truth.poses().size() + 1;
  while (static_cast<size_t>(std::count(replies.begin(), replies.end(), '\n')) < expected) {
    pollfd p{bridge.get(), POLLIN, 0};
    ASSERT_GT(::poll(&p, 1, 10000), 0) << "replies so far:\n" << replies;
    char buf[4096];
    const ssize_t n = ::recv(bridge.get(), buf, sizeof(buf), 0);
    ASSERT_GT(n, 0) << "the daemon closed the bridge's connection after "
                    << std::count(replies.begin(), replies.end(), '\n') << " of " << expected
                    << " replies:\n"
                    << replies.substr(replies.size() > 300 ? replies.size() - 300 : 0);
    replies.append(buf, static_cast<size_t>(n));
  }
  EXPECT_EQ(std::count(replies.begin(), replies.end(), '\n'),
            static_cast<std::ptrdiff_t>(expected));
  EXPECT_NE(replies.find("{\"error\":\"odom: "), std::string::npos) << replies;
  EXPECT_EQ(daemon.Status()["scale"]["odometry"]["samples"].get<size_t>(), truth.poses().size());

  const json result = daemon.TriggerAndWait(120s);
  ASSERT_TRUE(result.value("ok", false)) << result.dump() << "\n" << daemon.log();
  const EntryReport report = ReadReport(result["entry"].get<std::string>());
  EXPECT_EQ(report.scale.source, "odometry") << report.scale.why_not;
  EXPECT_EQ(report.scale.units, "metres");
  const std::optional<Eigen::Isometry3d> world_from_a =
      truth.WorldFromCamAt(report.keyframe_a.source_time_s);
  const std::optional<Eigen::Isometry3d> world_from_b =
      truth.WorldFromCamAt(report.keyframe_b.source_time_s);
  ASSERT_TRUE(world_from_a && world_from_b);
  const double baseline_m = (world_from_b->translation() - world_from_a->translation()).norm();
  std::cout << "[ figures  ] odometry baseline " << baseline_m << " m, entry "
            << report.relative_pose.translation.norm() << " m\n";
  EXPECT_NEAR(report.scale.metres_per_unit, baseline_m, 1e-3 * baseline_m);
  EXPECT_NEAR(report.relative_pose.translation.norm(), baseline_m, 1e-3 * baseline_m);
  bridge.reset();

  DaemonProcess without("odom_none", "rate=realtime&loop=0", scale_keys);
  without.Start();
  const json unscaled = without.TriggerAndWait(120s);
  ASSERT_TRUE(unscaled.value("ok", false)) << unscaled.dump() << "\n" << without.log();
  const EntryReport none = ReadReport(unscaled["entry"].get<std::string>());
  EXPECT_EQ(none.scale.source, "none");
  EXPECT_EQ(none.scale.units, "baseline");
  EXPECT_NE(none.scale.why_not.find("no odometry received"), std::string::npos)
      << none.scale.why_not;
}

// 48 connections held without a word: each beyond the cap of 32 takes the slot of the one idle
// longest, which is answered "busy" and closed; the daemon keeps serving.
TEST(Daemon, ClientsBeyondTheCapEvictTheOneIdleLongest) {
  DaemonProcess daemon("ctlcap", "rate=realtime&loop=1");
  daemon.Start();
  std::vector<UniqueFd> held;
  for (int i = 0; i < 48; ++i) {
    held.push_back(ConnectRaw(daemon.socket()));
    std::this_thread::sleep_for(2ms);  // Distinct accept times: "idle longest" is the oldest.
  }
  std::vector<bool> busy(held.size(), false);
  for (size_t i = 0; i < held.size(); ++i) {
    ASSERT_TRUE(held[i].valid());
    pollfd p{held[i].get(), POLLIN, 0};
    if (::poll(&p, 1, i < 16 ? 2000 : 50) <= 0) continue;
    char buf[256];
    const ssize_t n = ::recv(held[i].get(), buf, sizeof(buf), 0);
    busy[i] = n > 0 && std::string(buf, static_cast<size_t>(n)).find("busy") != std::string::npos;
  }
  EXPECT_EQ(std::count(busy.begin(), busy.begin() + 16, true), 16);
  EXPECT_EQ(std::count(busy.begin() + 16, busy.end(), true), 0);
  // A client that asks is served even with the slots full of idle connections.
  EXPECT_TRUE(daemon.Command("ping").value("ok", false));
  held.clear();
  EXPECT_TRUE(daemon.Command("ping").value("ok", false));
  EXPECT_EQ(WEXITSTATUS(daemon.Kill(SIGTERM)), 0);
}

// CPU seconds the process's main thread (the event loop) has used.
double LoopCpuSeconds(pid_t pid) {
  std::ifstream in("/proc/" + std::to_string(pid) + "/task/" + std::to_string(pid) + "/stat");
  std::string stat((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  std::istringstream fields(stat.substr(stat.rfind(')') + 2));
  std::string field;
  double ticks = 0;
  for (int i = 3; i <= 15 && fields >> field; ++i) {
    if (i == 14 || i == 15) ticks += std::stod(field);  // utime, stime.
  }
  return ticks / static_cast<double>(::sysconf(_SC_CLK_TCK));
}

// At the fd limit accept() fails with EMFILE while the connection stays pending: the loop
// backs off instead of spinning (it spun at 92 % CPU), and serves again once fds are free.
TEST(Daemon, FdLimitOnAcceptBacksOffWithoutSpinning) {
  // UBSan's vptr check probes the object's memory through a pipe of its own (libsanitizer's
  // IsAccessibleMemoryRange), which cannot open at the fd limit: it then calls every virtual
  // call an invalid vptr and halts the daemon. The default build runs this test.
  if (std::getenv("UBSAN_OPTIONS") != nullptr) {
    GTEST_SKIP() << "UBSan's vptr check needs a free descriptor";
  }
  DaemonProcess daemon("emfile", "rate=realtime&loop=1");
  daemon.Start();
  const fs::path fd_dir = "/proc/" + std::to_string(daemon.pid()) + "/fd";
  const auto open_fds = std::distance(fs::directory_iterator(fd_dir), fs::directory_iterator());
  rlimit normal{};
  ASSERT_EQ(::prlimit(daemon.pid(), RLIMIT_NOFILE, nullptr, &normal), 0) << std::strerror(errno);
  const rlimit limit{static_cast<rlim_t>(open_fds + 2), normal.rlim_max};
  ASSERT_EQ(::prlimit(daemon.pid(), RLIMIT_NOFILE, &limit, nullptr), 0) << std::strerror(errno);
  std::vector<UniqueFd> clients;
  for (int i = 0; i < 6; ++i) clients.push_back(ConnectRaw(daemon.socket()));
  std::this_thread::sleep_for(300ms);
  const double cpu_before = LoopCpuSeconds(daemon.pid());
  std::this_thread::sleep_for(2s);
  const double cpu = LoopCpuSeconds(daemon.pid()) - cpu_before;
  EXPECT_LT(cpu, 0.4) << "the event loop used " << cpu << " s of CPU in 2 s at the fd limit";
  clients.clear();
  ASSERT_EQ(::prlimit(daemon.pid(), RLIMIT_NOFILE, &normal, nullptr), 0) << std::strerror(errno);
  bool answered = false;
  for (int i = 0; i < 50 && !answered; ++i) {
    try {
      answered = daemon.Command("ping").value("ok", false);
    } catch (const ControlError&) {
      std::this_thread::sleep_for(100ms);
    }
  }
  EXPECT_TRUE(answered) << daemon.log();
  EXPECT_EQ(WEXITSTATUS(daemon.Kill(SIGTERM)), 0);
}

TEST(Daemon, MissingGpioChipIsReportedWithTheChip) {
  DaemonProcess daemon("nogpio", "rate=max",
                       "[trigger]\ngpio_chip = \"gpiochip-monomesh-absent\"\ngpio_line = \"4\"\n");
  std::string log;
  EXPECT_EQ(RunDaemonExpectingExit(daemon.dir() / "monomeshd.toml", &log), 69);
  EXPECT_NE(log.find("gpiochip-monomesh-absent"), std::string::npos) << log;
}

TEST(Daemon, MissingCameraFolderIsReportedWithThePath) {
  DaemonProcess daemon("nocamera", "rate=max");
  std::string text = ReadFile(daemon.dir() / "monomeshd.toml");
  text.replace(text.find("replay:") + 7, kData.string().size(), "/nonexistent/cam");
  std::ofstream(daemon.dir() / "monomeshd.toml") << text;
  std::string log;
  EXPECT_NE(RunDaemonExpectingExit(daemon.dir() / "monomeshd.toml", &log), 0);
  EXPECT_NE(log.find("/nonexistent/cam"), std::string::npos) << log;
}

// Rotation only (homography warps K R K^-1 of one keyframe, up to 9 deg of yaw, ~90 px of image
// motion) at 30 fps: the gate never takes keyframe B, even with a small threshold.
TEST(Daemon, RotationOnlySequenceNeverTakesKeyframeB) {
  const fs::path dir = FreshTempDir("rotation");
  fs::create_directories(dir / "rgb");
  const cv::Mat a = cv::imread((kData / "rgb/1341847982.730674.png").string());
  Eigen::Matrix3d k;
  k << 535.4, 0, 320.1, 0, 539.2, 247.6, 0, 0, 1;
  const std::vector<cv::Mat> frames = RotationOnlySequence(a, k, 30);
  std::ofstream list(dir / "rgb.txt");
  for (size_t i = 0; i < frames.size(); ++i) {
    const std::string file = "rgb/" + std::to_string(i) + ".png";
    cv::imwrite((dir / file).string(), frames[i]);
    list << 1000.0 + static_cast<double>(i) / 30.0 << " " << file << "\n";
  }
  list.close();
  fs::copy_file(kData / "calib.toml", dir / "calib.toml");
  DaemonProcess daemon("rotation", "rate=realtime&loop=0",
                       // Even a gate and a reconstruction that accept 0.05 deg of parallax.
                       "[keyframes]\nparallax_deg = 0.05\ntimeout_s = 3.0\n"
                       "[recon]\nmin_parallax_deg = 0.05\n",
                       dir);
  daemon.Start();
  const json result = daemon.TriggerAndWait(30s);
  EXPECT_FALSE(result.value("ok", true)) << result.dump();
  EXPECT_NE(result.value("error", "").find("not enough motion"), std::string::npos)
      << result.dump() << "\n"
      << daemon.log();
  EXPECT_EQ(daemon.log().find("keyframe B ="), std::string::npos) << daemon.log();
  EXPECT_TRUE(VisibleEntries(daemon.spool()).empty());
}

// The camera (here the replay folder) disappears mid-run and comes back: errors are reported,
// frames resume and a capture succeeds, all without a restart.
TEST(Daemon, SurvivesCameraDisappearingAndReturning) {
  const fs::path data = CopyOfBundledData("vanish");
  DaemonProcess daemon("vanish", "rate=realtime&speed=8&loop=1", "", data);
  daemon.Start();
  const fs::path away = data.string() + ".away";
  fs::rename(data / "rgb", away);
  std::this_thread::sleep_for(1s);
  const json gone = daemon.Status()["camera"];
  EXPECT_GT(gone["errors"].get<int>(), 0) << gone.dump();
  EXPECT_NE(gone["last_error"].get<std::string>().find(data.string()), std::string::npos)
      << gone.dump();
  fs::rename(away, data / "rgb");
  const uint64_t frames_before = daemon.Status()["camera"]["frames"].get<uint64_t>();
  std::this_thread::sleep_for(1s);
  EXPECT_GT(daemon.Status()["camera"]["frames"].get<uint64_t>(), frames_before);
  json result = json::object();
  for (int attempt = 0; attempt < 5 && !result.value("ok", false); ++attempt) {
    result = daemon.TriggerAndWait(60s);
  }
  EXPECT_TRUE(result.value("ok", false)) << result.dump() << "\n" << daemon.log();
}

// A spool on a small filesystem that fills up: the failure is reported (status and log), the
// earlier entries are intact, nothing half-written is left, and the daemon keeps serving.
TEST(Daemon, FullDiskIsReportedAndEarlierEntriesSurvive) {
  if (::geteuid() != 0) GTEST_SKIP() << "needs root to mount a small tmpfs";
  DaemonProcess daemon("fulldisk", "rate=realtime&speed=8&loop=1");
  fs::create_directories(daemon.spool());
  ASSERT_EQ(::mount("tmpfs", daemon.spool().c_str(), "tmpfs", 0, "size=4m"), 0)
      << std::strerror(errno);
  struct Unmount {
    fs::path path;
    ~Unmount() { ::umount2(path.c_str(), MNT_DETACH); }
  } unmount{daemon.spool()};
  daemon.Start();
  std::vector<json> results;
  for (int i = 0; i < 10 && (results.empty() || !results.back().value("ok", false)); ++i) {
    results.push_back(daemon.TriggerAndWait(60s));
  }
  ASSERT_TRUE(results.back().value("ok", false)) << "no first entry; log:\n" << daemon.log();
  // Fill the filesystem to 20 KB short of full (a dot-name: watchers and the daemon skip it).
  struct statvfs fs_stat {};
  ASSERT_EQ(::statvfs(daemon.spool().c_str(), &fs_stat), 0);
  const uint64_t free_bytes = static_cast<uint64_t>(fs_stat.f_bavail) * fs_stat.f_frsize;
  std::ofstream(daemon.spool() / ".filler", std::ios::binary)
      << std::string(free_bytes - 20 * 1024, 'f');
  for (int i = 0; i < 10; ++i) {
    results.push_back(daemon.TriggerAndWait(60s));
    if (results.back().value("error", "").find("spool write failed") != std::string::npos) break;
  }
  const json& last = results.back();
  ASSERT_NE(last.value("error", "").find("No space left on device"), std::string::npos)
      << last.dump() << "\n"
      << daemon.log();
  EXPECT_NE(daemon.log().find("spool write failed"), std::string::npos);
  const auto entries = VisibleEntries(daemon.spool());
  EXPECT_GE(entries.size(), 1u);
  for (const fs::path& entry : entries) ExpectCompleteEntry(entry);
  for (const auto& item : fs::directory_iterator(daemon.spool())) {
    EXPECT_NE(item.path().filename().string().rfind(".tmp-", 0), 0u) << item.path();
  }
  EXPECT_EQ(daemon.Status()["state"], "idle");  // Still serving.
  EXPECT_TRUE(daemon.Command("ping").value("ok", false));
}

}  // namespace
}  // namespace mm::test
