#pragma once
// A synthetic sequence several tests read, made once per ctest run: the fixture
// `synth/<name>` of tests/CMakeLists.txt (mm_synth_fixture) runs `monomesh synth` into the build
// folder and passes its path as MM_SYNTH_<NAME>. A test binary run by hand, outside ctest, makes
// the sequence itself with the same arguments. The tests only read it (their outputs go to
// their own temporary folders).

#include <cstdlib>
#include <filesystem>
#include <string>

#include "tests/support/run_command.h"

namespace mm::test {

/// A fixture of tests/CMakeLists.txt: the variable that names its folder, and the arguments it
/// gives `monomesh synth` (the same there).
struct SynthSequence {
  const char* env_name;
  const char* synth_args;
};
inline constexpr SynthSequence kCorridorWalkSeed2{
    "MM_SYNTH_CORRIDOR_WALK_SEED2",
    "--scene l-corridor --frames 300 --fps 30 --seed 2 --path walk"};
inline constexpr SynthSequence kCorridorWalkSeed3{
    "MM_SYNTH_CORRIDOR_WALK_SEED3",
    "--scene l-corridor --frames 240 --fps 30 --seed 3 --path walk"};

/// The sequence of fixture `env_name` (null: none), or `monomesh synth <synth_args>` made into
/// `fallback_dir`/seq; "" (and `*error` set) when synth failed.
inline std::filesystem::path SynthFixture(const char* env_name, const std::string& synth_args,
                                          const std::filesystem::path& fallback_dir,
                                          std::string* error) {
  if (const char* dir = env_name != nullptr ? std::getenv(env_name) : nullptr;
      dir != nullptr && *dir != '\0') {
    if (std::filesystem::exists(std::filesystem::path(dir) / "rgb.txt")) return dir;
    *error = std::string(env_name) + "=" + dir + " has no rgb.txt (did its fixture fail?)";
    return {};
  }
  const std::filesystem::path seq = fallback_dir / "seq";
  int status = 0;
  const std::string out =
      RunCommand(Monomesh() + " synth --out " + seq.string() + " " + synth_args, &status);
  if (status != 0) {
    *error = out;
    return {};
  }
  return seq;
}

inline std::filesystem::path SynthFixture(const SynthSequence& sequence,
                                          const std::filesystem::path& fallback_dir,
                                          std::string* error) {
  return SynthFixture(sequence.env_name, sequence.synth_args, fallback_dir, error);
}

}  // namespace mm::test
