// libFuzzer target for the Calib_Results.m reader (the fuzz preset; scripts/fuzz.sh).
// Any input either parses or throws CalibrationError; what parses must survive the writer and
// read back to the same values.

#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <string>

#include "calib/calib_io.h"
#include "calib/calib_results_m.h"

namespace {

bool Same(double a, double b) { return (std::isnan(a) && std::isnan(b)) || a == b; }

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  (void)mm::LooksLikeCalibResultsM(text);
  mm::CalibResults parsed;
  try {
    parsed = mm::ParseCalibResultsM(text, "fuzz.m");
  } catch (const mm::CalibrationError&) {
    return 0;
  }
  const mm::CalibResults again = mm::ParseCalibResultsM(mm::FormatCalibResultsM(parsed), "again");
  const auto p = parsed.camera.Intrinsics(), q = again.camera.Intrinsics();
  for (int i = 0; i < p.size(); ++i) {
    if (!Same(p[i], q[i])) std::abort();
  }
  if (again.images.size() != parsed.images.size() || again.n_ima != parsed.n_ima) std::abort();
  for (size_t k = 0; k < parsed.images.size(); ++k) {
    if (parsed.images[k].active != again.images[k].active) std::abort();
    for (int j = 0; j < 3; ++j) {
      if (parsed.images[k].active && !Same(parsed.images[k].tc[j], again.images[k].tc[j])) {
        std::abort();
      }
    }
  }
  return 0;
}
