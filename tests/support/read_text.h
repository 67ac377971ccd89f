#pragma once
// A whole (small) text file as a string, "" when it cannot be read.

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

namespace mm::test {

inline std::string ReadText(const std::filesystem::path& p) {
  std::ifstream in(p);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

}  // namespace mm::test
