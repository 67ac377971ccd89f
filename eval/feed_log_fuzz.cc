// libFuzzer target for the feed log `monomesh eval --spool --feed-log` reads (the fuzz preset;
// scripts/fuzz.sh). Any input is rows sorted by write start, each ending after it starts, or
// an error naming the line.

#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <string>

#include "eval/entry_eval.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  std::string error;
  const std::vector<mm::FedFrame> rows = mm::ParseFeedLog(text, "feed.log", &error);
  if (!error.empty()) {
    if (!rows.empty() || error.find("feed.log:") != 0) std::abort();
    return 0;
  }
  for (size_t i = 0; i < rows.size(); ++i) {
    if (!(rows[i].write_end_s >= rows[i].write_start_s)) std::abort();
    if (i > 0 && rows[i].write_start_s < rows[i - 1].write_start_s) std::abort();
  }
  return 0;
}
