// libFuzzer target for the stored calibration TOML reader (the fuzz preset; scripts/fuzz.sh).
// Any input either parses or throws CalibrationError; what parses is a valid camera (Check()
// holds, so its distortion inverts over the image) and survives the writer exactly.

#include <cstdint>
#include <cstdlib>
#include <string>

#include "calib/calib_io.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  mm::BouguetCamera camera;
  try {
    camera = mm::ParseCalibrationToml(text, "fuzz.toml");
  } catch (const mm::CalibrationError&) {
    return 0;
  }
  if (!camera.Check().empty()) std::abort();
  const mm::BouguetCamera again =
      mm::ParseCalibrationToml(mm::FormatCalibrationToml(camera), "again.toml");
  if (again.Intrinsics() != camera.Intrinsics() || again.width != camera.width ||
      again.height != camera.height || again.error.has_value() != camera.error.has_value()) {
    std::abort();
  }
  return 0;
}
