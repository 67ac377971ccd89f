#include "app/hooks.h"

#include <gtest/gtest.h>
#include <signal.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <thread>

#include "tests/support/read_file.h"
#include "tests/support/temp_dir.h"

namespace mm {
namespace {

namespace fs = std::filesystem;
using namespace std::chrono_literals;

// Real children (/bin/sh): waits until Reap reports `count` ended hooks, killing overdue ones,
// for at most `limit`.
std::vector<HookEnd> WaitForEnds(HookRunner* runner, size_t count,
                                 std::chrono::milliseconds limit = 10s) {
  std::vector<HookEnd> ended;
  const auto deadline = std::chrono::steady_clock::now() + limit;
  while (ended.size() < count && std::chrono::steady_clock::now() < deadline) {
    runner->KillOverdue();
    for (HookEnd& e : runner->Reap()) ended.push_back(std::move(e));
    std::this_thread::sleep_for(10ms);
  }
  return ended;
}

using test::ReadFile;

// A pid is gone once it has no process, or only a zombie waiting for its (new) parent.
bool Gone(pid_t pid) {
  const std::string stat = ReadFile("/proc/" + std::to_string(pid) + "/stat");
  if (stat.empty()) return true;
  const size_t paren = stat.rfind(')');
  return paren != std::string::npos && paren + 2 < stat.size() && stat[paren + 2] == 'Z';
}

fs::path TempDir(const std::string& name) { return test::FreshTempDir("hooks_" + name); }

// Hooks start programs of the machine (/bin/sh). A cross build's test runs under qemu-user,
// which cannot exec them without binfmt_misc (cmake/MonomeshHelpers.cmake): skipped there.
class HookRunnerTest : public ::testing::Test {
 protected:
  void SetUp() override {
    if (const char* emulator = std::getenv("MM_TEST_EMULATOR"); emulator && *emulator) {
      GTEST_SKIP() << "under " << emulator << ": no program of the machine can be started";
    }
  }
};

TEST(SplitHookCommand, WordsAtSpacesAndTabsWithoutQuoting) {
  EXPECT_EQ(SplitHookCommand("  /usr/bin/upload\t--to  host 'a b' "),
            (std::vector<std::string>{"/usr/bin/upload", "--to", "host", "'a", "b'"}));
  EXPECT_TRUE(SplitHookCommand(" \t ").empty());
}

TEST_F(HookRunnerTest, OnEntryGetsTheEntryAsItsLastArgumentAndInItsEnvironment) {
  const fs::path dir = TempDir("entry");
  const fs::path out = dir / "out.txt";
  HookRunner runner({.on_entry = {"/bin/sh", "-c",
                                  "printf '%s|%s|%s|%s' \"$1\" \"$MONOMESH_ENTRY\" "
                                  "\"$MONOMESH_CAPTURE\" \"$MONOMESH_HOOK\" > " +
                                      out.string(),
                                  "hook"}});
  const HookStart started = runner.OnEntry("/spool/entry one", 7);
  EXPECT_TRUE(started.started);
  EXPECT_NE(started.message.find("hook on_entry started"), std::string::npos) << started.message;
  const HookStart none = runner.OnFailure("anything", 7);  // No on_failure configured.
  EXPECT_FALSE(none.started);
  EXPECT_EQ(none.message, "");
  const std::vector<HookEnd> ended = WaitForEnds(&runner, 1);
  ASSERT_EQ(ended.size(), 1u);
  EXPECT_TRUE(ended[0].ok) << ended[0].how;
  EXPECT_EQ(ended[0].how, "exited 0");
  EXPECT_EQ(ended[0].name, "on_entry");
  EXPECT_FALSE(ended[0].timed_out);
  EXPECT_EQ(ReadFile(out), "/spool/entry one|/spool/entry one|7|on_entry");
  EXPECT_EQ(runner.running(), 0u);
  fs::remove_all(dir);
}

TEST_F(HookRunnerTest, AFailingHookReportsItsExitStatus) {
  HookRunner runner(
      {.on_failure = {"/bin/sh", "-c", "test \"$1\" = 'lost track' && exit 3", "hook"}});
  runner.OnFailure("lost track", 1);
  const std::vector<HookEnd> ended = WaitForEnds(&runner, 1);
  ASSERT_EQ(ended.size(), 1u);
  EXPECT_FALSE(ended[0].ok);
  EXPECT_EQ(ended[0].how, "exited 3");
}

// The limit kills the hook's whole group: a shell's background child too, not only the shell.
TEST_F(HookRunnerTest, AHangingHookIsKilledAtItsLimitWithWhatItStarted) {
  const fs::path dir = TempDir("hang");
  const fs::path pid_file = dir / "child.pid";
  HookRunner runner(
      {.on_entry = {"/bin/sh", "-c", "sleep 60 & echo $! > " + pid_file.string() + "; sleep 60",
                    "hook"},
       .timeout_s = 0.3});
  runner.OnEntry("/spool/e", 1);
  const std::vector<HookEnd> ended = WaitForEnds(&runner, 1);
  ASSERT_EQ(ended.size(), 1u);
  EXPECT_TRUE(ended[0].timed_out);
  EXPECT_FALSE(ended[0].ok);
  EXPECT_NE(ended[0].how.find("signal 9"), std::string::npos) << ended[0].how;
  EXPECT_GE(ended[0].seconds, 0.3);
  EXPECT_LT(ended[0].seconds, 5.0);
  const pid_t child = std::stoi(ReadFile(pid_file));
  bool gone = false;
  for (int i = 0; i < 200 && !gone; ++i, std::this_thread::sleep_for(10ms)) gone = Gone(child);
  EXPECT_TRUE(gone) << "the hook's background child " << child << " outlived it";
  fs::remove_all(dir);
}

TEST_F(HookRunnerTest, BeyondTheRunningCapAHookIsSkippedAndSaysWhy) {
  HookRunner runner({.on_entry = {"/bin/sleep"}, .max_running = 1});
  EXPECT_TRUE(runner.OnEntry("60", 1).started);
  const HookStart second = runner.OnEntry("60", 2);
  EXPECT_FALSE(second.started);
  EXPECT_NE(second.message.find("not run: 1 hooks still running"), std::string::npos)
      << second.message;
  EXPECT_EQ(runner.running(), 1u);
}

TEST_F(HookRunnerTest, AProgramThatCannotStartIsNamed) {
  HookRunner runner({.on_entry = {"/nonexistent/upload"}});
  const HookStart error = runner.OnEntry("/spool/e", 1);
  EXPECT_FALSE(error.started);
  EXPECT_NE(error.message.find("/nonexistent/upload"), std::string::npos) << error.message;
  EXPECT_EQ(runner.running(), 0u);
}

TEST_F(HookRunnerTest, GoingAwayKillsTheHooksStillRunning) {
  pid_t pid = -1;
  {
    HookRunner runner({.on_entry = {"/bin/sleep"}});
    const std::string started = runner.OnEntry("60", 1).message;
    pid = std::stoi(started.substr(started.find("pid ") + 4));
  }
  EXPECT_TRUE(Gone(pid));
}

}  // namespace
}  // namespace mm
