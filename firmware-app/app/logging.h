#pragma once
#include <string>

namespace mm {
/// Logs to stderr at `level` (trace|debug|info|warn|error). Under systemd (JOURNAL_STREAM set)
/// each line starts with its syslog priority "<N>" so journald files it at that level; on a
/// terminal lines carry timestamps; otherwise "level message".
void SetupLogging(const std::string& level);
}  // namespace mm
