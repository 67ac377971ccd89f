// libFuzzer target for the TUM image list reader (the replay camera's list and `monomesh eval
// --list`) and the replay's time-order check (the fuzz preset; scripts/fuzz.sh). Any input
// parses or throws DatasetError; every frame parsed has a finite time, a path and its line.

#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <string>

#include "dataset/tum.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  std::vector<mm::TumFrame> frames;
  try {
    frames = mm::ParseTumList(text, "/data", "fuzz.txt");
  } catch (const mm::DatasetError&) {
    return 0;
  }
  if (frames.empty()) std::abort();
  int last_line = 0;
  for (const mm::TumFrame& f : frames) {
    if (!std::isfinite(f.timestamp_s) || f.path.empty() || f.line <= last_line) std::abort();
    last_line = f.line;
  }
  (void)mm::CheckTimeOrder(frames, 60.0, "fuzz.txt");
  return 0;
}
