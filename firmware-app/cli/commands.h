#pragma once
// Subcommands of the `monomesh` tool. Each lives in its own file and registers itself on the
// CLI11 app; main() only collects them (firmware-app/monomesh_main.cc).

#include <CLI/CLI.hpp>
#include <functional>
#include <string>
#include <vector>

namespace mm::cli {

/// Exit code of a command refusing an input file's content (sysexits.h EX_DATAERR; a GLB whose
/// accessors overrun its buffers, docs/exit_codes.md).
inline constexpr int kExitDataError = 65;

/// An option that has an effect only when `holds()` after parsing (a mode, or another option's
/// value): what CLI11's needs/excludes cannot say.
struct OptionRule {
  std::string option;           ///< As on the command line, e.g. "--odom-noise-m".
  std::function<bool()> holds;  ///< Reads the parsed values.
  std::string needed;           ///< What it needs, e.g. "--scale odometry or --scale auto".
};

/// Checks `rules` once `cmd` is parsed: a rule whose option was given but does not hold is
/// CLI11's RequiresError ("--a requires <needed>", its exit code 107), like needs().
inline void AddOptionRules(CLI::App* cmd, std::vector<OptionRule> rules) {
  cmd->callback([cmd, rules = std::move(rules)] {
    for (const OptionRule& rule : rules) {
      if (cmd->count(rule.option) > 0 && !rule.holds()) {
        throw CLI::RequiresError(rule.option, rule.needed);
      }
    }
  });
}

/// What a registered subcommand runs once parsed; returns the process exit code.
using Runner = std::function<int()>;

/// Adds `recon`: one pair of images -> mesh files in a folder.
Runner AddReconCommand(CLI::App& app);
/// Adds `eval`: two-view accuracy and timing on a TUM-format folder (eval/tum_pairs.h).
Runner AddEvalCommand(CLI::App& app);
/// Adds `ctl`: trigger | status | ping a running monomeshd.
Runner AddCtlCommand(CLI::App& app);
/// Adds `feed`: plays a dataset into a v4l2loopback device.
Runner AddFeedCommand(CLI::App& app);
/// Adds `gpio-watch`: prints button events of a GPIO line.
Runner AddGpioWatchCommand(CLI::App& app);
/// Adds `calibrate`: chessboard images -> Calib_Results.m, calibration.toml, report PNG.
Runner AddCalibrateCommand(CLI::App& app);
/// Adds `snapshot`: calibration views from the appliance's own camera.
Runner AddSnapshotCommand(CLI::App& app);
/// Adds `undistort`: one image through a calibration's remap tables.
Runner AddUndistortCommand(CLI::App& app);
/// Adds `render`: a mesh (GLB) seen from a camera -> PNG (and depth), headless EGL.
Runner AddRenderCommand(CLI::App& app);
/// Adds `report`: a spool entry's report, read through entry/'s typed reader.
Runner AddReportCommand(CLI::App& app);
/// Adds `synth`: a synthetic corridor sequence with exact ground truth (synth/sequence.h).
Runner AddSynthCommand(CLI::App& app);

}  // namespace mm::cli
