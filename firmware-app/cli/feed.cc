// `monomesh feed`: plays a dataset into a v4l2loopback device, so any V4L2 program (the daemon
// included) sees the dataset as a real camera.

#include <algorithm>
#include <chrono>
#include <csignal>
#include <fstream>
#include <iostream>
#include <thread>

#include "capture/loopback_feeder.h"
#include "capture/replay_source.h"
#include "cli/commands.h"

namespace mm::cli {
namespace {

using namespace std::chrono_literals;

volatile std::sig_atomic_t g_feed_stop = 0;
volatile std::sig_atomic_t g_go = 0;
volatile std::sig_atomic_t g_steps = 0;  // SIGUSR2s received (--step).

int RunFeed(const std::string& device, const std::string& dataset, double fps,
            const std::string& format_name, bool loop, int64_t count, bool hold_first,
            bool hold_last, bool step, const std::string& log_path) {
  using Clock = std::chrono::steady_clock;
  const auto format = ParsePixelFormat(format_name);
  if (!format || (*format != PixelFormat::kGrey && *format != PixelFormat::kYuyv)) {
    std::cerr << "monomesh feed: format '" << format_name << "' (expected grey or yuyv)\n";
    return 2;
  }
  ReplayOptions ro;
  ro.realtime = false;
  ro.loop = loop;
  ReplaySource replay(dataset, ro);
  if (std::string e = replay.Open(); !e.empty()) {
    std::cerr << "monomesh feed: " << e << "\n";
    return 1;
  }
  std::signal(SIGINT, [](int) { g_feed_stop = 1; });
  std::signal(SIGTERM, [](int) { g_feed_stop = 1; });
  std::signal(SIGUSR1, [](int) { g_go = 1; });
  std::signal(SIGUSR2, [](int) { g_steps = g_steps + 1; });
  // The feed log maps the device's timestamps (v4l2loopback stamps a frame with
  // CLOCK_MONOTONIC when it is written) back to the dataset frame: `monomesh eval --spool
  // --feed-log` evaluates the daemon's keyframes with it.
  std::ofstream log;
  if (!log_path.empty()) {
    log.open(log_path);
    if (!log) {
      std::cerr << "monomesh feed: cannot write the log " << log_path << "\n";
      return 1;
    }
    log << "# monomesh feed " << dataset << " -> " << device
        << ": write_start_s write_end_s (CLOCK_MONOTONIC) dataset_time_s\n";
    log.setf(std::ios::fixed);
    log.precision(6);
  }
  LoopbackFeeder feeder;
  const auto period =
      std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(1.0 / fps));
  auto next = Clock::now();
  int64_t written = 0;
  int steps_taken = 0;
  Frame frame;
  bool ended = false;
  while (!g_feed_stop && (count <= 0 || written < count)) {
    // --hold-first: the first frame again (a camera standing still) until SIGUSR1;
    // --step: the current frame again until the next SIGUSR2, until SIGUSR1 plays on;
    // --hold-last: the last frame again after the end, until SIGTERM or SIGINT.
    const bool stepping = step && !g_go;
    const bool next_step = stepping && written > 0 && g_steps > steps_taken;
    if (next_step) ++steps_taken;
    const bool hold =
        (hold_first && written > 0 && !g_go) || (stepping && written > 0 && !next_step) || ended;
    if (!hold) {
      std::string error;
      const ReadStatus s = replay.Read(&frame, std::chrono::milliseconds(1000), &error);
      if (s == ReadStatus::kEndOfStream && hold_last && written > 0) {
        ended = true;
        std::cerr << "end of " << dataset << " after " << written << " frames; holding the last\n";
        continue;
      }
      if (s == ReadStatus::kEndOfStream) break;
      if (s != ReadStatus::kFrame) {
        std::cerr << "monomesh feed: " << error << "\n";
        return 1;
      }
    }
    if (written == 0) {
      if (std::string e = feeder.Open(device, frame.image.cols, frame.image.rows, *format, fps);
          !e.empty()) {
        std::cerr << "monomesh feed: " << e << "\n";
        return 1;
      }
      std::cerr << "feeding " << dataset << " into " << device << " as " << PixelFormatName(*format)
                << " " << frame.image.cols << "x" << frame.image.rows << " at " << fps << " fps\n";
    }
    const int64_t before_ns = MonotonicNowNs();
    if (std::string e = feeder.Write(frame.image); !e.empty()) {
      std::cerr << "monomesh feed: " << e << "\n";
      return 1;
    }
    if (log.is_open()) {  // The driver's timestamp lies between the two.
      log << 1e-9 * static_cast<double>(before_ns) << " "
          << 1e-9 * static_cast<double>(MonotonicNowNs()) << " " << frame.source_time_s
          << std::endl;  // Whole lines if killed.
    }
    ++written;
    next += period;
    // A step is played at once, not at the next tick.
    while (Clock::now() < next && !g_feed_stop && !(stepping && g_steps > steps_taken) &&
           !(stepping && g_go)) {
      std::this_thread::sleep_for(std::min<Clock::duration>(next - Clock::now(), 10ms));
    }
    if (Clock::now() < next) next = Clock::now();
  }
  std::cerr << "fed " << written << " frames\n";
  return 0;
}

}  // namespace

Runner AddFeedCommand(CLI::App& app) {
  auto* cmd = app.add_subcommand("feed", "Play a dataset into a v4l2loopback device");
  struct Args {
    std::string device, dataset, format = "yuyv";
    double fps = 30;
    bool once = false;
    bool hold_first = false;
    bool hold_last = false;
    bool step = false;
    int64_t count = 0;
    std::string log;
  };
  auto args = std::make_shared<Args>();
  cmd->add_option("--device", args->device, "v4l2loopback device, e.g. /dev/video10")->required();
  cmd->add_option("--dataset", args->dataset, "TUM-format folder (rgb.txt)")
      ->required()
      ->check(CLI::ExistingDirectory);
  cmd->add_option("--fps", args->fps, "Frames per second")
      ->capture_default_str()
      ->check(CLI::Range(0.1, 1000.0));
  cmd->add_option("--format", args->format, "grey | yuyv")->capture_default_str();
  auto* once = cmd->add_flag("--once", args->once, "Play the dataset once instead of looping");
  cmd->add_option("--count", args->count, "Stop after this many frames (0: no limit)");
  cmd->add_flag("--hold-first", args->hold_first,
                "Repeat the first frame (a camera standing still) until SIGUSR1, then play on");
  cmd->add_flag("--hold-last", args->hold_last,
                "With --once: after the end, repeat the last frame (a camera standing still) until "
                "SIGTERM")
      ->needs(once);
  cmd->add_flag("--step", args->step,
                "Play one frame per SIGUSR2, repeating the current one at --fps in between (a "
                "camera that moves as fast as the program reading it keeps up), until SIGUSR1 "
                "plays on at --fps")
      ->excludes("--hold-first");
  cmd->add_option("--log", args->log,
                  "Log each frame's write interval (CLOCK_MONOTONIC) and dataset time (for "
                  "monomesh eval --feed-log)");
  return [cmd, args]() -> int {
    if (!cmd->parsed()) return -1;
    return RunFeed(args->device, args->dataset, args->fps, args->format, !args->once, args->count,
                   args->hold_first, args->hold_last, args->step, args->log);
  };
}

}  // namespace mm::cli
