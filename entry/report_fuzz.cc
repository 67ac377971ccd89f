// libFuzzer target for the report.json readers, a pair's and a walk's (`monomesh eval --spool`
// reads every entry's; the fuzz preset, scripts/fuzz.sh). Any bytes are refused or read; what is
// read is written (never throwing, whatever its strings hold) and reads back to the same text.

#include <cstdint>
#include <cstdlib>
#include <nlohmann/json.hpp>
#include <string>

#include "entry/report.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  const nlohmann::json j = nlohmann::json::parse(text, nullptr, /*allow_exceptions=*/false);
  if (j.is_discarded()) return 0;
  if (mm::ReportKind(j) == "walk") {
    mm::WalkReport walk;
    if (!mm::FromJson(j, &walk).empty()) return 0;
    const std::string written = mm::FormatWalkReport(walk);
    mm::WalkReport again;
    if (!mm::FromJson(nlohmann::json::parse(written), &again).empty()) std::abort();
    if (mm::FormatWalkReport(again) != written) std::abort();
    return 0;
  }
  mm::EntryReport report;
  if (!mm::FromJson(j, &report).empty()) return 0;
  const std::string written = mm::FormatEntryReport(report);
  mm::EntryReport again;
  if (!mm::FromJson(nlohmann::json::parse(written), &again).empty()) std::abort();
  if (mm::FormatEntryReport(again) != written) std::abort();
  return 0;
}
