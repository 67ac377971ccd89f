// libFuzzer target for monomeshd.toml (the fuzz preset; scripts/fuzz.sh). Any input is a
// config or a ConfigError naming the file; a config read has every number in its key's range
// and passes the options' own checks.

#include <cstdint>
#include <cstdlib>
#include <string>

#include "app/config.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  mm::DaemonConfig config;
  try {
    config = mm::ParseDaemonConfig(text, "/etc/monomesh/monomeshd.toml");
  } catch (const mm::ConfigError& e) {
    if (std::string(e.what()).find("/etc/monomesh/monomeshd.toml") == std::string::npos) {
      std::abort();
    }
    return 0;
  }
  if (!config.recon.Check().empty() || !config.gate.Check().empty()) std::abort();
  if (config.button_enabled && !config.button.Check().empty()) std::abort();
  if (config.control_mode < 0 || config.control_mode > 0777) std::abort();
  if (config.spool_max_entries < 0 || !(config.keyframe_timeout_s > 0)) std::abort();
  return 0;
}
