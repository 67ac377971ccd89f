// The checks that run inside the qemu guest of tests/kernel/run.sh, against real kernel drivers
// (v4l2loopback, vivid, gpio-sim, vimc through libcamera). Each subcommand prints "CHECK <name> PASS|FAIL <detail>" and
// exits 0 on PASS. Deliberately free of OpenCV imgcodecs (the guest has few libraries): the
// dataset comes as binary PPM files decoded on the host by `kernel_prepare`.

#include <execinfo.h>
#include <poll.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <map>
#include <string>
#include <thread>
#include <vector>

#include "capture/libcamera_source.h"
#include "capture/loopback_feeder.h"
#include "capture/pixel_format.h"
#include "capture/trigger.h"
#include "capture/v4l2_source.h"

namespace mm {
namespace {

using namespace std::chrono_literals;
using Clock = std::chrono::steady_clock;

int Report(const std::string& name, bool pass, const std::string& detail) {
  std::printf("CHECK %s %s %s\n", name.c_str(), pass ? "PASS" : "FAIL", detail.c_str());
  std::fflush(stdout);
  return pass ? 0 : 1;
}

std::map<std::string, std::string> Args(int argc, char** argv) {
  std::map<std::string, std::string> out;
  for (int i = 2; i + 1 < argc; i += 2) out[argv[i]] = argv[i + 1];
  return out;
}

// Reads a binary PPM (P6, maxval 255) as BGR8.
cv::Mat ReadPpm(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::string magic;
  int w = 0, h = 0, maxval = 0;
  in >> magic >> w >> h >> maxval;
  in.get();
  if (magic != "P6" || w <= 0 || h <= 0 || maxval != 255) return {};
  cv::Mat rgb(h, w, CV_8UC3);
  in.read(reinterpret_cast<char*>(rgb.data), static_cast<std::streamsize>(rgb.total() * 3));
  if (!in) return {};
  for (int y = 0; y < h; ++y) {
    auto* p = rgb.ptr<uint8_t>(y);
    for (int x = 0; x < w; ++x) std::swap(p[3 * x], p[3 * x + 2]);
  }
  return rgb;
}

std::vector<cv::Mat> ReadFrames(const std::string& dir) {
  std::vector<cv::Mat> frames;
  for (int i = 0;; ++i) {
    cv::Mat m = ReadPpm(dir + "/" + std::to_string(i) + ".ppm");
    if (m.empty()) break;
    frames.push_back(m);
  }
  return frames;
}

// V4l2Options for a device (source_uri.cc is avoided: it pulls the replay camera and codecs).
V4l2Options V4l2(const std::string& device, const std::string& format, int width = 0, int height = 0,
                 bool gray = false) {
  V4l2Options o;
  o.device = device;
  o.format = ParsePixelFormat(format);
  o.width = width;
  o.height = height;
  o.gray = gray;
  return o;
}

bool Same(const cv::Mat& a, const cv::Mat& b) {
  return a.size() == b.size() && a.type() == b.type() && cv::norm(a, b, cv::NORM_INF) == 0;
}

// Feeds `frames` (in order, looping) into a loopback device from a thread, through the
// project's LoopbackFeeder, at `fps` until stopped.
class FeedThread {
 public:
  FeedThread(std::string device, std::vector<cv::Mat> frames, PixelFormat format, double fps)
      : device_(std::move(device)), frames_(std::move(frames)), format_(format), fps_(fps) {}
  ~FeedThread() { Stop(); }
  std::string Start() {
    error_ = feeder_.Open(device_, frames_[0].cols, frames_[0].rows, format_, fps_);
    if (!error_.empty()) return error_;
    stop_ = false;
    thread_ = std::thread([this] {
      auto next = Clock::now();
      for (size_t i = 0; !stop_; ++i) {
        if (std::string e = feeder_.Write(frames_[i % frames_.size()]); !e.empty()) {
          error_ = e;
          return;
        }
        next += std::chrono::microseconds(static_cast<int64_t>(1e6 / fps_));
        std::this_thread::sleep_until(next);
      }
    });
    return {};
  }
  void Stop() {
    stop_ = true;
    if (thread_.joinable()) thread_.join();
  }
  void Close() {
    Stop();
    feeder_.Close();
  }

 private:
  std::string device_;
  std::vector<cv::Mat> frames_;
  PixelFormat format_;
  double fps_;
  LoopbackFeeder feeder_;
  std::thread thread_;
  std::atomic<bool> stop_{false};
  std::string error_;
};

// Reads until `n` non-empty frames arrived or `limit` passed, with reads of `timeout`. With
// `lost`, stops at the first error and stores it there.
int CountFrames(FrameSource& source, int n, std::chrono::seconds limit, std::chrono::milliseconds timeout,
                std::string* lost) {
  int got = 0;
  const auto end = Clock::now() + limit;
  while (got < n && Clock::now() < end) {
    Frame f;
    std::string error;
    const ReadStatus s = source.Read(&f, timeout, &error);
    if (s == ReadStatus::kFrame && !f.image.empty()) ++got;
    if (s == ReadStatus::kError && lost) {
      *lost = error;
      return got;
    }
  }
  return got;
}

// Dataset -> feeder -> v4l2loopback -> V4l2Source: each frame read back equals a fed frame
// bit for bit (GREY: the gray bytes fed; YUYV: the YUYV bytes fed, compared after the same
// conversion and on the raw luma).
int CheckLoopback(const std::map<std::string, std::string>& a) {
  const std::string device = a.at("--device"), fmt = a.at("--format");
  const std::string name = "loopback-" + fmt + "-bitexact";
  const auto format = *ParsePixelFormat(fmt);
  const std::vector<cv::Mat> frames = ReadFrames(a.at("--frames"));
  if (frames.empty()) return Report(name, false, "no frames in " + a.at("--frames"));
  // What V4l2Source must deliver for each fed frame (gray=1 for GREY, BGR for YUYV).
  std::vector<cv::Mat> expected;
  for (const cv::Mat& f : frames) {
    std::string bytes;
    EncodeForFeed(f, format, &bytes);
    cv::Mat e;
    ConvertRaw(format, reinterpret_cast<const uint8_t*>(bytes.data()), bytes.size(), f.cols, f.rows,
               0, format == PixelFormat::kGrey, &e);
    expected.push_back(e);
  }
  FeedThread feed(device, frames, format, 10);
  if (std::string e = feed.Start(); !e.empty()) return Report(name, false, e);
  std::this_thread::sleep_for(200ms);
  V4l2Source source(V4l2(device, fmt, 0, 0, format == PixelFormat::kGrey));
  if (std::string e = source.Open(); !e.empty()) return Report(name, false, e);
  int matched = 0, mismatched = 0, distinct = 0;
  int last = -1;
  const auto deadline = Clock::now() + 20s;
  while (matched < 12 && Clock::now() < deadline) {
    Frame f;
    std::string error;
    const ReadStatus s = source.Read(&f, 1000ms, &error);
    if (s == ReadStatus::kError) return Report(name, false, error);
    if (s != ReadStatus::kFrame) continue;
    int which = -1;
    for (size_t i = 0; i < expected.size(); ++i) {
      if (Same(f.image, expected[i])) which = static_cast<int>(i);
    }
    if (which < 0) {
      ++mismatched;
      continue;
    }
    ++matched;
    if (which != last) ++distinct;
    last = which;
  }
  const bool pass = matched >= 12 && mismatched == 0 && distinct >= 6;
  return Report(name, pass,
                source.Describe() + ": " + std::to_string(matched) + " frames identical to fed ones (" +
                    std::to_string(distinct) + " distinct), " + std::to_string(mismatched) +
                    " differing");
}

// vivid in a given format: frames of the negotiated size with picture content.
int CheckVivid(const std::map<std::string, std::string>& a) {
  const std::string device = a.at("--device"), fmt = a.at("--format");
  const std::string name = "vivid-" + fmt;
  V4l2Source source(V4l2(device, fmt, 640, 360));
  if (std::string e = source.Open(); !e.empty()) return Report(name, false, e);
  int frames = 0;
  uint64_t last_seq = 0;
  double stddev = 0;
  const auto deadline = Clock::now() + 30s;
  while (frames < 3 && Clock::now() < deadline) {
    Frame f;
    std::string error;
    const ReadStatus s = source.Read(&f, 2000ms, &error);
    if (s == ReadStatus::kError) return Report(name, false, error);
    if (s != ReadStatus::kFrame) continue;
    if (f.image.cols != 640 || f.image.rows != 360 || f.image.type() != CV_8UC3) {
      return Report(name, false, "frame " + std::to_string(f.image.cols) + "x" + std::to_string(f.image.rows));
    }
    cv::Scalar mean, sd;
    cv::meanStdDev(f.image, mean, sd);
    stddev = sd[0];
    last_seq = f.sequence;
    ++frames;
  }
  return Report(name, frames == 3 && stddev > 5,
                source.Describe() + ": " + std::to_string(frames) + " frames, last sequence " +
                    std::to_string(last_seq) + ", stddev " + std::to_string(stddev));
}

// Bad requests against a real device give errors naming the device and what it offers.
int CheckErrors(const std::map<std::string, std::string>& a) {
  const std::string device = a.at("--device");
  V4l2Source bad_size(V4l2(device, "yuyv", 123, 45));
  const std::string e1 = bad_size.Open();
  V4l2Source busy1(V4l2(device, "yuyv"));
  const std::string open1 = busy1.Open();
  V4l2Source busy2(V4l2(device, "yuyv"));
  const std::string e2 = busy2.Open();
  const bool pass = e1.find(device) != std::string::npos && e1.find("offers") != std::string::npos &&
                    open1.empty() && e2.find("busy") != std::string::npos;
  return Report("v4l2-errors", pass, "[" + e1 + "] [" + e2 + "]");
}

// gpio-sim: edges driven through the sysfs 'pull' file reach GpioButton; a burst of edges
// inside the debounce time is one press.
int CheckGpio(const std::map<std::string, std::string>& a) {
  const std::string pull_file = a.at("--pull");
  auto pull = [&](const char* v) {
    std::ofstream(pull_file) << v;
  };
  pull("pull-up");  // Released (active-low button).
  std::this_thread::sleep_for(50ms);
  GpioButtonOptions o;
  o.chip = a.at("--chip");
  o.line = a.at("--line");
  o.debounce_ms = 100;
  o.report_release = true;
  GpioButton button(o);
  if (std::string e = button.Open(); !e.empty()) return Report("gpio-edges", false, e);
  int presses = 0, releases = 0;
  auto drain = [&](std::chrono::milliseconds for_how_long) {
    const auto end = Clock::now() + for_how_long;
    while (Clock::now() < end) {
      pollfd p{button.fd(), POLLIN, 0};
      if (::poll(&p, 1, 20) <= 0) continue;
      TriggerEvent ev;
      std::string error;
      if (button.ReadEvent(&ev, &error) == 1) (ev.pressed ? presses : releases)++;
    }
  };
  // One clean press and release.
  pull("pull-down");
  drain(300ms);
  pull("pull-up");
  drain(300ms);
  const int clean_edges = static_cast<int>(button.edges());
  Report("gpio-edges", presses == 1 && releases == 1 && clean_edges == 2,
         button.Describe() + ": " + std::to_string(clean_edges) + " edges, " + std::to_string(presses) +
             " press, " + std::to_string(releases) + " release");
  // A bouncing press: 7 edges a few ms apart, then held.
  presses = releases = 0;
  for (int i = 0; i < 4; ++i) {
    pull("pull-down");
    if (i < 3) pull("pull-up");
  }
  drain(400ms);
  pull("pull-up");
  drain(300ms);
  const int burst_edges = static_cast<int>(button.edges()) - clean_edges;
  return Report("gpio-debounce", presses == 1 && burst_edges >= 5,
                std::to_string(burst_edges) + " edges in the burst -> " + std::to_string(presses) +
                    " press (" + std::to_string(button.bounces()) + " bounces dropped)") |
         (clean_edges == 2 ? 0 : 1);
}

// The device disappears while streaming (vivid unbound from its driver: ENODEV) and comes
// back (bound again): the same V4l2Source reports the loss and delivers frames again.
int CheckUnplug(const std::map<std::string, std::string>& a) {
  const std::string device = a.at("--device"), driver_dir = a.at("--driver"), dev_name = a.at("--name");
  const std::string name = "unplug-recovery";
  V4l2Options options = V4l2(device, "yuyv", 320, 180);
  options.reopen_min_ms = 50;
  options.reopen_max_ms = 400;
  V4l2Source source(options);
  if (std::string e = source.Open(); !e.empty()) return Report(name, false, e);
  auto read_frames = [&](int n, std::chrono::seconds limit, std::string* lost) {
    return CountFrames(source, n, limit, 500ms, lost);
  };
  const int before = read_frames(2, 20s, nullptr);
  std::ofstream(driver_dir + "/unbind") << dev_name;
  std::string lost;
  read_frames(1000, 10s, &lost);
  std::this_thread::sleep_for(500ms);
  std::ofstream(driver_dir + "/bind") << dev_name;
  const int after = read_frames(2, 30s, nullptr);
  const bool pass = before == 2 && lost.find("lost") != std::string::npos && after == 2 &&
                    source.reopens() >= 1;
  return Report(name, pass, std::to_string(before) + " frames, unbind -> [" + lost + "], bind -> " +
                                std::to_string(after) + " frames after " +
                                std::to_string(source.reopens()) + " reopen(s)");
}

// The loopback writer stalls (no frame for timeout_ms): reported lost; the writer comes back
// and capture resumes in the same process.
int CheckLoopbackStall(const std::map<std::string, std::string>& a) {
  const std::string device = a.at("--device");
  const std::string name = "loopback-stall-recovery";
  const std::vector<cv::Mat> frames = ReadFrames(a.at("--frames"));
  if (frames.empty()) return Report(name, false, "no frames");
  auto feed = std::make_unique<FeedThread>(device, frames, PixelFormat::kGrey, 10);
  if (std::string e = feed->Start(); !e.empty()) return Report(name, false, e);
  std::this_thread::sleep_for(200ms);
  V4l2Options options = V4l2(device, "grey", 0, 0, true);
  options.lost_after_ms = 1000;
  options.reopen_min_ms = 50;
  options.reopen_max_ms = 400;
  V4l2Source source(options);
  if (std::string e = source.Open(); !e.empty()) return Report(name, false, e);
  int before = 0, after = 0;
  std::string lost;
  auto end = Clock::now() + 10s;
  while (before < 3 && Clock::now() < end) {
    Frame f;
    std::string error;
    if (source.Read(&f, 500ms, &error) == ReadStatus::kFrame) ++before;
  }
  feed->Stop();  // The writer stalls, device still there.
  end = Clock::now() + 10s;
  while (lost.empty() && Clock::now() < end) {
    Frame f;
    std::string error;
    if (source.Read(&f, 500ms, &error) == ReadStatus::kError) lost = error;
  }
  feed = std::make_unique<FeedThread>(device, frames, PixelFormat::kGrey, 10);
  std::string restart_error = feed->Start();
  end = Clock::now() + 15s;
  while (after < 3 && Clock::now() < end) {
    Frame f;
    std::string error;
    if (source.Read(&f, 500ms, &error) == ReadStatus::kFrame) ++after;
  }
  return Report(name, before == 3 && !lost.empty() && after == 3,
                std::to_string(before) + " frames, stall -> [" + lost + "], writer back" +
                    (restart_error.empty() ? "" : " (" + restart_error + ")") + " -> " +
                    std::to_string(after) + " frames, " + std::to_string(source.reopens()) +
                    " reopen(s)");
}

// The loopback device removed while streaming and added back, in one process with one
// V4l2Source: the writer goes away, the source reports the loss and closes the device (so the
// module can go: v4l2loopback 0.12.7 cannot delete a device that is open), the module is
// removed (/dev/videoN disappears; the back-off reopens fail), loaded again, the writer comes
// back, and the same source delivers frames again.
int CheckLoopbackRemove(const std::map<std::string, std::string>& a) {
  const std::string device = a.at("--device");
  const std::string name = "loopback-removed-recovery";
  const std::vector<cv::Mat> frames = ReadFrames(a.at("--frames"));
  if (frames.empty()) return Report(name, false, "no frames");
  auto read_frames = [](V4l2Source& source, int n, std::chrono::seconds limit, std::string* lost) {
    return CountFrames(source, n, limit, 200ms, lost);
  };
  auto feed = std::make_unique<FeedThread>(device, frames, PixelFormat::kGrey, 10);
  if (std::string e = feed->Start(); !e.empty()) return Report(name, false, e);
  std::this_thread::sleep_for(200ms);
  V4l2Options options = V4l2(device, "grey", 0, 0, true);
  options.lost_after_ms = 1000;
  options.reopen_min_ms = 50;
  options.reopen_max_ms = 400;
  V4l2Source source(options);
  if (std::string e = source.Open(); !e.empty()) return Report(name, false, e);
  const int before = read_frames(source, 3, 10s, nullptr);
  feed.reset();  // The writer closes the device.
  std::string lost;
  read_frames(source, 1000, 10s, &lost);
  // The source has closed the device: the module can be removed now.
  const int removed = std::system(a.at("--remove").c_str());
  const bool gone = ::access(device.c_str(), F_OK) != 0;
  const int while_gone = read_frames(source, 1, 2s, nullptr);  // Reopen attempts fail.
  const std::string described_gone = source.Describe();
  const int added = std::system(a.at("--add").c_str());
  std::string restart_error = "device node did not come back";
  for (auto end = Clock::now() + 10s; Clock::now() < end; std::this_thread::sleep_for(100ms)) {
    if (::access(device.c_str(), F_OK) != 0) continue;
    feed = std::make_unique<FeedThread>(device, frames, PixelFormat::kGrey, 10);
    restart_error = feed->Start();
    if (restart_error.empty()) break;
  }
  const int after = read_frames(source, 3, 20s, nullptr);
  const bool pass = before == 3 && lost.find("lost") != std::string::npos && removed == 0 &&
                    gone && while_gone == 0 && added == 0 && after == 3 && source.reopens() >= 1;
  return Report(name, pass,
                std::to_string(before) + " frames, writer gone -> [" + lost + "], module removed (" +
                    (gone ? device + " gone" : device + " still there") + ", " +
                    std::to_string(while_gone) + " frames, [" + described_gone +
                    "]), module added" + (restart_error.empty() ? "" : " (" + restart_error + ")") +
                    " -> " + std::to_string(after) + " frames after " +
                    std::to_string(source.reopens()) + " reopen(s)");
}

// libcamera lists vimc's camera and LibcameraSource captures from it.
int CheckLibcamera(const std::map<std::string, std::string>& a) {
  const std::string want = a.at("--camera");
  std::string error;
  const std::vector<std::string> ids = ListLibcameraCameras(&error);
  std::string listed;
  for (const auto& id : ids) listed += "'" + id + "' ";
  const bool found = std::find(ids.begin(), ids.end(), want) != ids.end();
  Report("libcamera-list", found, "libcamera lists " + std::to_string(ids.size()) + " camera(s): " + listed + error);
  if (!found) return 1;
  LibcameraOptions o;
  o.camera = want;
  o.lost_after_ms = 20000;
  LibcameraSource source(o);
  if (std::string e = source.Open(); !e.empty()) return Report("libcamera-capture", false, e);
  int frames = 0;
  double stddev = 0;
  cv::Size size;
  const auto deadline = Clock::now() + 60s;
  while (frames < 3 && Clock::now() < deadline) {
    Frame f;
    std::string e;
    const ReadStatus s = source.Read(&f, 2000ms, &e);
    if (s == ReadStatus::kError) return Report("libcamera-capture", false, e);
    if (s != ReadStatus::kFrame) continue;
    cv::Scalar mean, sd;
    cv::meanStdDev(f.image, mean, sd);
    stddev = sd[0];
    size = f.image.size();
    ++frames;
  }
  const std::string desc = source.Describe();
  source.Close();
  return Report("libcamera-capture", frames == 3 && stddev > 1,
                desc + ": " + std::to_string(frames) + " frames " + std::to_string(size.width) + "x" +
                    std::to_string(size.height) + ", stddev " + std::to_string(stddev));
}

// LibcameraSource survives what libcamera 0.0.3 itself does not: its worker process killed
// while streaming (a crash inside libcamera), and vimc unbound and bound again while streaming
// (the camera removed and added back; libcamera's enumerator crashes on the re-add). Both are
// reported as a loss and capture resumes in the same source, without a restart.
int CheckLibcameraUnplug(const std::map<std::string, std::string>& a) {
  const std::string want = a.at("--camera"), driver_dir = a.at("--driver"), dev_name = a.at("--name");
  LibcameraOptions o;
  o.camera = want;
  o.lost_after_ms = 10000;  // Frames are slow under TCG.
  o.open_timeout_ms = 60000;
  o.reopen_min_ms = 200;
  o.reopen_max_ms = 2000;
  LibcameraSource source(o);
  if (std::string e = source.Open(); !e.empty()) return Report("libcamera-worker-crash", false, e);
  auto read_frames = [&](int n, std::chrono::seconds limit, std::string* lost) {
    return CountFrames(source, n, limit, 1000ms, lost);
  };
  // 1. The worker dies (SIGKILL stands in for libcamera crashing).
  const int before = read_frames(2, 60s, nullptr);
  const pid_t first = source.worker_pid();
  if (first > 0) kill(first, SIGKILL);
  std::string killed;
  read_frames(1000, 30s, &killed);
  const int after_kill = read_frames(2, 90s, nullptr);
  const bool crash_pass = before == 2 && killed.find("killed by signal 9") != std::string::npos &&
                          after_kill == 2 && source.worker_pid() > 0 && source.worker_pid() != first;
  Report("libcamera-worker-crash", crash_pass,
         std::to_string(before) + " frames, worker " + std::to_string(first) + " killed -> [" + killed +
             "] -> " + std::to_string(after_kill) + " frames from worker " + std::to_string(source.worker_pid()));
  // 2. The camera removed and added back.
  const uint64_t reopens_before = source.reopens();
  std::ofstream(driver_dir + "/unbind") << dev_name;
  std::string lost;
  read_frames(1000, 60s, &lost);
  int while_gone = 0;
  const auto gone_until = Clock::now() + 4s;
  while (Clock::now() < gone_until) while_gone += read_frames(1, 1s, nullptr);
  const std::string described_gone = source.Describe();
  std::ofstream(driver_dir + "/bind") << dev_name;
  const int settle = std::system("udevadm settle --timeout=60");
  const int after = read_frames(3, 120s, nullptr);
  const bool pass = crash_pass && lost.find("lost") != std::string::npos && while_gone == 0 && after == 3 &&
                    source.reopens() > reopens_before;
  const std::string desc = source.Describe();
  source.Close();
  return Report("libcamera-unplug-recovery", pass,
                "unbind " + dev_name + " -> [" + lost + "], " + std::to_string(while_gone) + " frames while gone [" +
                    described_gone + "], bind (udevadm settle " + std::to_string(settle) + ") -> " +
                    std::to_string(after) + " frames after " + std::to_string(source.reopens() - reopens_before) +
                    " reopen(s) [" + desc + "]");
}

}  // namespace
}  // namespace mm

int main(int argc, char** argv) {
  // A crash in the guest prints where it happened (there is no debugger there).
  for (int sig : {SIGSEGV, SIGABRT, SIGBUS}) {
    std::signal(sig, [](int s) {
      void* frames[64];
      const int n = backtrace(frames, 64);
      (void)!write(STDERR_FILENO, "kernel_checks: fatal signal, backtrace:\n", 40);
      backtrace_symbols_fd(frames, n, STDERR_FILENO);
      std::signal(s, SIG_DFL);
      std::raise(s);
    });
  }
  if (argc < 2) {
    std::fprintf(stderr, "usage: kernel_checks loopback|vivid|errors|gpio|unplug|stall --key value...\n");
    return 2;
  }
  const std::string cmd = argv[1];
  const auto a = mm::Args(argc, argv);
  try {
    if (cmd == "loopback") return mm::CheckLoopback(a);
    if (cmd == "vivid") return mm::CheckVivid(a);
    if (cmd == "errors") return mm::CheckErrors(a);
    if (cmd == "gpio") return mm::CheckGpio(a);
    if (cmd == "unplug") return mm::CheckUnplug(a);
    if (cmd == "stall") return mm::CheckLoopbackStall(a);
    if (cmd == "remove") return mm::CheckLoopbackRemove(a);
    if (cmd == "libcamera") return mm::CheckLibcamera(a);
    if (cmd == "libcamera-unplug") return mm::CheckLibcameraUnplug(a);
  } catch (const std::exception& e) {
    return mm::Report(cmd, false, std::string("exception: ") + e.what());
  }
  std::fprintf(stderr, "kernel_checks: unknown check '%s'\n", cmd.c_str());
  return 2;
}
