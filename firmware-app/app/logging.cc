#include "app/logging.h"

#include "app/config.h"

#include <spdlog/pattern_formatter.h>
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>
#include <unistd.h>

#include <cstdlib>

namespace mm {
namespace {

// "<N>" syslog priority prefix (sd-daemon(3)): journald files each line at its level.
class SyslogPrefix final : public spdlog::custom_flag_formatter {
 public:
  void format(const spdlog::details::log_msg& msg, const std::tm&,
              spdlog::memory_buf_t& dest) override {
    static constexpr char kPriority[] = {'7', '7', '6', '4', '3', '2', '6'};  // trace..off
    const char text[] = {'<', kPriority[static_cast<int>(msg.level)], '>'};
    dest.append(text, text + 3);
  }
  [[nodiscard]] std::unique_ptr<custom_flag_formatter> clone() const override {
    return std::make_unique<SyslogPrefix>();
  }
};

}  // namespace

void SetupLogging(const std::string& level) {
  auto logger = spdlog::stderr_color_mt("monomesh");
  spdlog::set_default_logger(logger);
  spdlog::set_level(spdlog::level::from_str(level));
  auto formatter = std::make_unique<spdlog::pattern_formatter>();
  if (std::getenv("JOURNAL_STREAM") != nullptr) {
    // Under systemd: journald stamps lines; the prefix carries the level.
    formatter->add_flag<SyslogPrefix>('*').set_pattern("%*%v");
  } else if (::isatty(STDERR_FILENO)) {
    formatter->set_pattern("%Y-%m-%d %H:%M:%S.%e %^%-5l%$ %v");
  } else {
    formatter->set_pattern("%-5l %v");
  }
  spdlog::set_formatter(std::move(formatter));
  spdlog::flush_on(spdlog::level::info);
}

int LoadConfigAndSetupLogging(const std::string& path, DaemonConfig* config) {
  try {
    *config = LoadDaemonConfig(path);
  } catch (const ConfigError& e) {
    SetupLogging("info");
    spdlog::critical("config: {}", e.what());
    return 78;  // EX_CONFIG: systemd does not restart on it (RestartPreventExitStatus=78).
  } catch (const std::exception& e) {
    SetupLogging("info");
    spdlog::critical("internal error reading {}: {}", path, e.what());
    return 70;  // EX_SOFTWARE
  }
  SetupLogging(config->log_level);
  return 0;
}

}  // namespace mm
