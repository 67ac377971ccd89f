#pragma once
// A fresh, empty folder for a test under the system's temporary directory, named
// mm_<name>_<pid> so parallel test processes never share one.

#include <unistd.h>

#include <filesystem>
#include <string>

namespace mm::test {

inline std::filesystem::path FreshTempDir(const std::string& name) {
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() / ("mm_" + name + "_" + std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir;
}

}  // namespace mm::test
