#pragma once
// Tests that read ../shared/data (data that may not be committed into the repo) call
// RequireSharedData() first: without the folder the whole test binary exits with 77, which
// ctest reports as skipped (SKIP_RETURN_CODE 77), and says why.

#include <cstdlib>
#include <filesystem>
#include <iostream>

namespace mm::test {

/// The shared data folder: $MM_SHARED_DATA, else <repo>/../shared/data.
inline std::filesystem::path SharedDataDir() {
  if (const char* env = std::getenv("MM_SHARED_DATA")) return env;
  return std::filesystem::path(MM_SOURCE_DIR).parent_path() / "shared" / "data";
}

/// Returns SharedDataDir()/sub, or exits 77 (skip) with a message when it is absent.
inline std::filesystem::path RequireSharedData(const std::filesystem::path& sub = {}) {
  const std::filesystem::path dir = SharedDataDir() / sub;
  if (!std::filesystem::exists(dir)) {
    std::cerr << "SKIP: " << dir.string()
              << " is absent (data that may not be committed; see ../shared/data/README.md)\n";
    std::exit(77);
  }
  return dir;
}

}  // namespace mm::test
