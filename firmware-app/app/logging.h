#pragma once
#include <string>

namespace mm {
/// Logs to stderr for journald: "<level> message" without our own timestamps when stderr is
/// not a terminal (journald stamps lines), with timestamps on a terminal.
void SetupLogging(const std::string& level);
}  // namespace mm
