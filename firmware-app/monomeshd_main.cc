// monomeshd: the capture-to-mesh appliance daemon. Wiring only: parse the command line, load
// the config, run the daemon (firmware-app/app/daemon.h).

#include <malloc.h>

#include <CLI/CLI.hpp>

#include "app/config.h"
#include "app/daemon.h"
#include "app/logging.h"
#include "base/version.h"

int main(int argc, char** argv) {
  // glibc gives each thread that allocates concurrently an arena of its own, up to 8 per core;
  // the capture, gate and worker threads each then keep freed pages the others cannot reuse.
  // Two arenas: peak RSS over three captures at 640x480 298 -> 289 MB (docs/recon_tuning.md).
  // Set before any thread starts.
  mallopt(M_ARENA_MAX, 2);
  CLI::App app{"monomeshd: capture-to-mesh camera appliance daemon"};
  app.set_version_flag("-V,--version", std::string("monomeshd ") + mm::kMonomeshVersion);
  std::string config_path = "/etc/monomesh/monomeshd.toml";
  app.add_option("-c,--config", config_path, "Config file (TOML)")->capture_default_str();
  CLI11_PARSE(app, argc, argv);

  // Exit codes: docs/exit_codes.md.
  mm::DaemonConfig config;
  if (const int code = mm::LoadConfigAndSetupLogging(config_path, &config); code != 0) return code;
  return mm::RunDaemon(config);
}
