#pragma once
#include <string>

namespace mm {
struct DaemonConfig;

/// Logs to stderr at `level` (trace|debug|info|warn|error). Under systemd (JOURNAL_STREAM set)
/// each line starts with its syslog priority "<N>" so journald files it at that level; on a
/// terminal lines carry timestamps; otherwise "level message".
void SetupLogging(const std::string& level);

/// What a program of the appliance does first: reads the config at `path` into *config and logs
/// at its [log] level. Returns 0, or the exit code after a critical line (docs/exit_codes.md):
/// 78 for a config error, 70 for an internal error while reading it.
int LoadConfigAndSetupLogging(const std::string& path, DaemonConfig* config);
}  // namespace mm
