#pragma once
// Folders for a test under the system's temporary directory, named mm_<name>_<pid> so parallel
// test processes never share one. Each is removed when its test process ends with every test
// passed and kept for a look when one failed (a suite run used to leave some 170 MB behind).

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <set>
#include <string>
#include <system_error>

namespace mm::test {

/// Removes the folders given to it at the end of the process if every test passed.
class RemovedWhenAllPass {
 public:
  static void Add(const std::filesystem::path& path) { Instance().paths_.insert(path); }

  RemovedWhenAllPass(const RemovedWhenAllPass&) = delete;
  RemovedWhenAllPass& operator=(const RemovedWhenAllPass&) = delete;

 private:
  RemovedWhenAllPass() = default;
  // Runs at exit, before GoogleTest's own singleton (made earlier, destroyed later) is gone.
  ~RemovedWhenAllPass() {
    if (!::testing::UnitTest::GetInstance()->Passed()) return;
    std::error_code ignored;
    for (const std::filesystem::path& path : paths_) std::filesystem::remove_all(path, ignored);
  }
  static RemovedWhenAllPass& Instance() {
    static RemovedWhenAllPass instance;
    return instance;
  }

  std::set<std::filesystem::path> paths_;
};

/// <temp>/mm_<name>_<pid>, not created; removed at the end if every test passed.
inline std::filesystem::path TestTempPath(const std::string& name) {
  const std::filesystem::path path =
      std::filesystem::temp_directory_path() / ("mm_" + name + "_" + std::to_string(::getpid()));
  RemovedWhenAllPass::Add(path);
  return path;
}

/// TestTempPath(name) as a fresh, empty folder.
inline std::filesystem::path FreshTempDir(const std::string& name) {
  const std::filesystem::path dir = TestTempPath(name);
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir;
}

}  // namespace mm::test
