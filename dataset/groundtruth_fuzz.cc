// libFuzzer target for the TUM ground-truth reader (`monomesh eval`'s groundtruth.txt; the
// fuzz preset, scripts/fuzz.sh). Any input parses or throws DatasetError; what parses is
// sorted, and every pose it interpolates is a rotation with a finite translation.

#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <optional>
#include <string>

#include "dataset/tum.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  std::optional<mm::Trajectory> trajectory;
  try {
    trajectory = mm::Trajectory::Parse(text, "groundtruth.txt");
  } catch (const mm::DatasetError&) {
    return 0;
  }
  const auto& poses = trajectory->poses();
  for (size_t i = 1; i < poses.size(); ++i) {
    if (poses[i].timestamp_s < poses[i - 1].timestamp_s) std::abort();
  }
  // Query at every sample and half way between neighbours.
  for (size_t i = 0; i < poses.size() && i < 64; ++i) {
    for (const double t :
         {poses[i].timestamp_s, i + 1 < poses.size()
                                    ? 0.5 * (poses[i].timestamp_s + poses[i + 1].timestamp_s)
                                    : poses[i].timestamp_s + 0.05}) {
      const std::optional<Eigen::Isometry3d> pose = trajectory->WorldFromCamAt(t);
      if (!pose) continue;
      const Eigen::Matrix3d r = pose->linear();
      if (!r.allFinite() || !((r.transpose() * r - Eigen::Matrix3d::Identity()).norm() < 1e-6)) {
        std::abort();
      }
    }
  }
  return 0;
}
