// `monomesh report ENTRY [--json]`: a spool entry's report.json read through the typed reader
// (entry/entry.h: ReadEntryReport), printed as BriefReport's `key value` lines, or as the
// whole report with --json. The scripts (demo, output checks) read entries through this.

#include <iostream>

#include "cli/commands.h"
#include "entry/entry.h"

namespace mm::cli {

Runner AddReportCommand(CLI::App& app) {
  auto* cmd = app.add_subcommand("report", "Print a spool entry's report (key value lines)");
  struct Args {
    std::string entry;
    bool json = false;
  };
  auto args = std::make_shared<Args>();
  cmd->add_option("entry", args->entry, "Spool entry folder (holds report.json)")
      ->required()
      ->check(CLI::ExistingDirectory);
  cmd->add_flag("--json", args->json, "Print the whole report as JSON");
  return [cmd, args]() -> int {
    if (!cmd->parsed()) return -1;
    EntryReport report;
    if (const std::string error = ReadEntryReport(args->entry, &report); !error.empty()) {
      std::cerr << "monomesh report: " << error << "\n";
      return 1;
    }
    std::cout << (args->json ? FormatEntryReport(report) : BriefReport(report));
    return 0;
  };
}

}  // namespace mm::cli
