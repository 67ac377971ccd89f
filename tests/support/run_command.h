#pragma once
// Runs a shell command for a test and returns what it printed (stdout and stderr) with its exit
// status; the programs under test come from ctest's environment (MONOMESH, MONOMESHD).

#include <sys/wait.h>

#include <cstdio>
#include <cstdlib>
#include <string>

namespace mm::test {

inline std::string RunCommand(const std::string& command, int* status) {
  std::string out;
  FILE* pipe = ::popen((command + " 2>&1").c_str(), "r");
  char buf[512];
  while (pipe != nullptr && std::fgets(buf, sizeof(buf), pipe) != nullptr) out += buf;
  *status = pipe != nullptr ? WEXITSTATUS(::pclose(pipe)) : -1;
  return out;
}

/// The `monomesh` CLI ctest points MONOMESH at ("" when run outside ctest).
inline std::string Monomesh() {
  const char* bin = std::getenv("MONOMESH");
  return bin != nullptr ? bin : "";
}

}  // namespace mm::test
