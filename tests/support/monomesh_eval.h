#pragma once
// `monomesh eval ARGS --json FILE` for a test: prints what it said, expects exit 0 and returns
// the JSON it wrote.

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <iostream>
#include <nlohmann/json.hpp>
#include <string>

#include "tests/support/run_command.h"

namespace mm::test {

inline nlohmann::json RunMonomeshEval(const std::string& args,
                                      const std::filesystem::path& json_file) {
  int status = 0;
  const std::string out =
      RunCommand(Monomesh() + " eval --json " + json_file.string() + " " + args, &status);
  std::cout << out;
  EXPECT_EQ(status, 0) << out;
  std::ifstream in(json_file);
  return nlohmann::json::parse(in);
}

}  // namespace mm::test
