// `monomesh gpio-watch --chip C --line L`: prints button events, for wiring checks.

#include <poll.h>

#include <csignal>
#include <cstdio>
#include <iostream>

#include "capture/trigger.h"
#include "cli/commands.h"

namespace mm::cli {
namespace {

volatile std::sig_atomic_t g_watch_stop = 0;

int RunGpioWatch(const GpioButtonOptions& options, int count, double seconds) {
  GpioButton button(options);
  if (std::string e = button.Open(); !e.empty()) {
    std::cerr << "monomesh gpio-watch: " << e << "\n";
    return 1;
  }
  std::signal(SIGINT, [](int) { g_watch_stop = 1; });
  std::signal(SIGTERM, [](int) { g_watch_stop = 1; });
  std::cout << "watching " << button.Describe() << " (Ctrl-C to stop)" << std::endl;
  int presses = 0;
  const auto deadline = std::chrono::steady_clock::now() +
                        std::chrono::milliseconds(static_cast<int64_t>(seconds * 1000));
  while (!g_watch_stop && (count <= 0 || presses < count)) {
    if (seconds > 0 && std::chrono::steady_clock::now() >= deadline) break;
    pollfd p{button.fd(), POLLIN, 0};
    if (::poll(&p, 1, 100) <= 0) continue;
    TriggerEvent ev;
    std::string error;
    const int r = button.ReadEvent(&ev, &error);
    if (r < 0) {
      std::cerr << "monomesh gpio-watch: " << error << "\n";
      return 1;
    }
    if (r == 0) continue;
    if (ev.pressed) ++presses;
    std::printf("%.6f %s %s\n", static_cast<double>(ev.time_ns) * 1e-9, ev.source.c_str(),
                ev.pressed ? "press" : "release");
    std::fflush(stdout);
  }
  std::printf("presses=%d edges=%llu bounces=%llu\n", presses,
              static_cast<unsigned long long>(button.edges()),
              static_cast<unsigned long long>(button.bounces()));
  return 0;
}

}  // namespace

Runner AddGpioWatchCommand(CLI::App& app) {
  auto* cmd = app.add_subcommand("gpio-watch", "Print button events of a GPIO line");
  auto options = std::make_shared<GpioButtonOptions>();
  auto count = std::make_shared<int>(0);
  auto seconds = std::make_shared<double>(0);
  auto active_high = std::make_shared<bool>(false);
  options->report_release = true;
  cmd->add_option("--chip", options->chip, "Chip name, number, path or label")
      ->capture_default_str();
  cmd->add_option("--line", options->line, "Line offset or name")->required();
  cmd->add_option("--debounce-ms", options->debounce_ms, "Debounce quiet time")
      ->capture_default_str();
  cmd->add_option("--bias", options->bias, "as-is | pull-up | pull-down | disable")
      ->capture_default_str();
  cmd->add_flag("--active-high", *active_high, "The line is high when pressed");
  cmd->add_option("--count", *count, "Exit after this many presses (0: no limit)");
  cmd->add_option("--seconds", *seconds, "Exit after this long (0: no limit)");
  return [=]() -> int {
    if (!cmd->parsed()) return -1;
    options->active_low = !*active_high;
    return RunGpioWatch(*options, *count, *seconds);
  };
}

}  // namespace mm::cli
