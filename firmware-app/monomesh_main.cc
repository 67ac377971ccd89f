// monomesh: the command-line tool. Wiring only: each subcommand is in firmware-app/cli/.

#include <CLI/CLI.hpp>
#include <iostream>
#include <vector>

#include "app/config.h"
#include "app/logging.h"
#include "base/version.h"
#include "calib/calib_io.h"
#include "cli/commands.h"

int main(int argc, char** argv) {
  CLI::App app{"monomesh: capture-to-mesh appliance tool"};
  app.set_version_flag("-V,--version", std::string("monomesh ") + mm::kMonomeshVersion);
  app.require_subcommand(1);
  const std::vector<mm::cli::Runner> runners{
      mm::cli::AddReconCommand(app),
      mm::cli::AddEvalCommand(app),
      mm::cli::AddCtlCommand(app),
      mm::cli::AddFeedCommand(app),
      mm::cli::AddGpioWatchCommand(app),
      mm::cli::AddCalibrateCommand(app),
      mm::cli::AddSnapshotCommand(app),
      mm::cli::AddUndistortCommand(app),
      mm::cli::AddRenderCommand(app),
      mm::cli::AddSynthCommand(app),
      mm::cli::AddReportCommand(app),
  };
  CLI11_PARSE(app, argc, argv);
  mm::SetupLogging("warn");
  try {
    for (const mm::cli::Runner& run : runners) {
      if (const int code = run(); code >= 0) return code;
    }
  } catch (const mm::CalibrationError& e) {
    std::cerr << "monomesh: calibration: " << e.what() << "\n";
    return 78;
  } catch (const mm::ConfigError& e) {
    std::cerr << "monomesh: config: " << e.what() << "\n";
    return 78;
  } catch (const std::exception& e) {
    std::cerr << "monomesh: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
