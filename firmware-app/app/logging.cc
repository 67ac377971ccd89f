#include "app/logging.h"

#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>
#include <unistd.h>

namespace mm {

void SetupLogging(const std::string& level) {
  auto logger = spdlog::stderr_color_mt("monomesh");
  spdlog::set_default_logger(logger);
  spdlog::set_level(spdlog::level::from_str(level));
  spdlog::set_pattern(::isatty(STDERR_FILENO) ? "%Y-%m-%d %H:%M:%S.%e %^%-5l%$ %v" : "%-5l %v");
  spdlog::flush_on(spdlog::level::info);
}

}  // namespace mm
