#pragma once
// A whole (small) file as a string, byte for byte; "" when it cannot be read.

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

namespace mm::test {

inline std::string ReadFile(const std::filesystem::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

}  // namespace mm::test
