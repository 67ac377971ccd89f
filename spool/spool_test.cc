#include "spool/spool.h"

#include <gtest/gtest.h>
#include <signal.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <fstream>
#include <sstream>
#include <thread>

#include "tests/support/read_file.h"
#include "tests/support/temp_dir.h"

namespace mm {
namespace {

namespace fs = std::filesystem;

fs::path FreshDir(const std::string& name) {
  const fs::path dir = test::TestTempPath("spool_" + name);
  fs::remove_all(dir);
  return dir;
}

using test::ReadFile;

TEST(Spool, CommitsWholeEntryWithIncreasingSequence) {
  const fs::path dir = FreshDir("commit");
  Spool spool({.dir = dir, .max_entries = 0});
  ASSERT_EQ(spool.Recover(), "");
  const SpoolCommit a = spool.Commit({{"report.json", "{}"}, {"mesh.ply", "ply"}}, 0);
  ASSERT_TRUE(a.ok) << a.error;
  EXPECT_EQ(a.entry.filename().string(), "19700101T000000Z-000001");
  EXPECT_EQ(ReadFile(a.entry / "mesh.ply"), "ply");
  EXPECT_EQ(a.bytes, 5u);
  const SpoolCommit b = spool.Commit({{"report.json", "{}"}}, 60);
  ASSERT_TRUE(b.ok);
  EXPECT_EQ(b.entry.filename().string(), "19700101T000100Z-000002");
  // A restarted daemon continues the sequence.
  Spool again({.dir = dir, .max_entries = 0});
  ASSERT_EQ(again.Recover(), "");
  EXPECT_EQ(again.Commit({{"x", "1"}}, 0).entry.filename().string(), "19700101T000000Z-000003");
  EXPECT_EQ(again.Entries().size(), 3u);
}

TEST(Spool, RejectsBadFileNamesWithoutLeavingAnything) {
  const fs::path dir = FreshDir("names");
  Spool spool({.dir = dir, .max_entries = 0});
  ASSERT_EQ(spool.Recover(), "");
  const SpoolCommit c = spool.Commit({{"ok.txt", "1"}, {"../escape", "2"}}, 0);
  EXPECT_FALSE(c.ok);
  EXPECT_NE(c.error.find("../escape"), std::string::npos);
  EXPECT_TRUE(fs::is_empty(dir));
}

TEST(Spool, RetentionKeepsNewest) {
  const fs::path dir = FreshDir("retention");
  Spool spool({.dir = dir, .max_entries = 2});
  ASSERT_EQ(spool.Recover(), "");
  for (int i = 0; i < 4; ++i) ASSERT_TRUE(spool.Commit({{"f", std::to_string(i)}}, i).ok);
  const auto entries = spool.Entries();
  ASSERT_EQ(entries.size(), 2u);
  EXPECT_EQ(ReadFile(entries[0] / "f"), "2");
  EXPECT_EQ(ReadFile(entries[1] / "f"), "3");
  // The two entries and `latest`.
  EXPECT_EQ(std::distance(fs::directory_iterator(dir), fs::directory_iterator()), 3);
}

// `latest` names the newest entry after each commit, is replaced by rename (no moment without
// it), is never an entry, and is left alone when it is not the spool's symlink.
TEST(Spool, LatestSymlinkNamesTheNewestEntry) {
  const fs::path dir = FreshDir("latest");
  Spool spool({.dir = dir, .max_entries = 2});
  ASSERT_EQ(spool.Recover(), "");
  EXPECT_FALSE(fs::exists(fs::symlink_status(dir / "latest")));
  for (int i = 0; i < 3; ++i) {
    const SpoolCommit c = spool.Commit({{"f", std::to_string(i)}}, i);
    ASSERT_TRUE(c.ok) << c.error;
    EXPECT_EQ(c.error, "");
    ASSERT_TRUE(fs::is_symlink(dir / "latest"));
    EXPECT_EQ(fs::read_symlink(dir / "latest"), c.entry.filename());  // Relative.
    EXPECT_EQ(ReadFile(dir / "latest" / "f"), std::to_string(i));
    EXPECT_FALSE(fs::exists(fs::symlink_status(dir / ".tmp-latest")));
  }
  EXPECT_EQ(spool.Entries().size(), 2u);  // Retention counts entries only.
  for (const fs::path& e : spool.Entries()) EXPECT_NE(e.filename(), "latest");

  // A leftover of an interrupted update is the spool's own and goes at the next start; the
  // sequence goes on from the entries, not from `latest`.
  fs::create_symlink("nowhere", dir / ".tmp-latest");
  Spool again({.dir = dir, .max_entries = 2});
  int removed = 0;
  ASSERT_EQ(again.Recover(&removed), "");
  EXPECT_EQ(removed, 1);
  EXPECT_FALSE(fs::exists(fs::symlink_status(dir / ".tmp-latest")));
  const SpoolCommit next = again.Commit({{"f", "3"}}, 3);
  ASSERT_TRUE(next.ok);
  EXPECT_EQ(next.entry.filename().string(), "19700101T000003Z-000004");
  EXPECT_EQ(fs::read_symlink(dir / "latest"), next.entry.filename());

  // An operator's `latest` (not a symlink) stays; the commit succeeds and says why.
  fs::remove(dir / "latest");
  fs::create_directories(dir / "latest");
  std::ofstream(dir / "latest" / "keep.txt") << "operator data";
  const SpoolCommit foreign = again.Commit({{"f", "4"}}, 4);
  ASSERT_TRUE(foreign.ok);
  EXPECT_NE(foreign.error.find("not a symlink"), std::string::npos) << foreign.error;
  EXPECT_EQ(ReadFile(dir / "latest" / "keep.txt"), "operator data");
  EXPECT_EQ(again.Entries().size(), 2u);
}

// Retention and recovery touch only names the spool made: an operator's archive/, a file, a
// folder whose name only looks similar, a symlink named like an entry, and a foreign dot-name
// survive, and none of them counts as an entry.
TEST(Spool, RetentionAndRecoveryLeaveForeignNamesAlone) {
  const fs::path dir = FreshDir("foreign");
  const fs::path outside = FreshDir("foreign_target");
  fs::create_directories(dir / "archive");
  std::ofstream(dir / "archive" / "keep.txt") << "operator data";
  std::ofstream(dir / "notes.txt") << "notes";
  fs::create_directories(dir / "20240101T000000Z-backup");
  fs::create_directories(dir / ".tmp-mine");
  fs::create_directories(outside);
  std::ofstream(outside / "x") << "x";
  fs::create_directory_symlink(outside, dir / "19990101T000000Z-000001");
  Spool spool({.dir = dir, .max_entries = 2});
  int removed = 0;
  ASSERT_EQ(spool.Recover(&removed), "");
  EXPECT_EQ(removed, 0);
  EXPECT_TRUE(spool.Entries().empty());
  for (int i = 0; i < 4; ++i) ASSERT_TRUE(spool.Commit({{"f", std::to_string(i)}}, i).ok);
  const auto entries = spool.Entries();
  ASSERT_EQ(entries.size(), 2u);
  EXPECT_EQ(ReadFile(entries[0] / "f"), "2");
  EXPECT_EQ(ReadFile(entries[1] / "f"), "3");
  EXPECT_EQ(ReadFile(dir / "archive" / "keep.txt"), "operator data");
  EXPECT_TRUE(fs::exists(dir / "notes.txt"));
  EXPECT_TRUE(fs::is_directory(dir / "20240101T000000Z-backup"));
  EXPECT_TRUE(fs::is_directory(dir / ".tmp-mine"));
  EXPECT_TRUE(fs::is_symlink(dir / "19990101T000000Z-000001"));
  EXPECT_EQ(ReadFile(outside / "x"), "x");
  Spool again({.dir = dir, .max_entries = 2});
  ASSERT_EQ(again.Recover(&removed), "");
  EXPECT_EQ(removed, 0);
  EXPECT_TRUE(fs::is_directory(dir / ".tmp-mine"));
  EXPECT_EQ(again.Entries().size(), 2u);
}

// A writer killed with SIGKILL in the middle of an entry leaves nothing visible; Recover()
// removes its leftovers.
TEST(Spool, KillDuringWriteLeavesNoVisibleEntry) {
  const fs::path dir = FreshDir("kill");
  {
    Spool spool({.dir = dir, .max_entries = 0});
    ASSERT_EQ(spool.Recover(), "");
  }
  const pid_t child = ::fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    Spool spool({.dir = dir, .max_entries = 0});
    if (!spool.Recover().empty()) ::_exit(1);
    std::vector<SpoolFile> files;
    for (int i = 0; i < 100; ++i) {
      files.push_back({"part" + std::to_string(i), std::string(1 << 20, 'x')});
    }
    (void)spool.Commit(files, 0);  // Killed while it writes: the result is never seen.
    ::_exit(0);
  }
  bool saw_temp = false;
  for (int i = 0; i < 20000 && !saw_temp; ++i) {
    for (const auto& item : fs::directory_iterator(dir)) {
      if (item.path().filename().string().rfind(Spool::kTempPrefix, 0) == 0 &&
          fs::exists(item.path() / "part1")) {
        saw_temp = true;
      }
    }
    if (!saw_temp) std::this_thread::sleep_for(std::chrono::microseconds(200));
  }
  ::kill(child, SIGKILL);
  int status = 0;
  ::waitpid(child, &status, 0);
  ASSERT_TRUE(saw_temp) << "the writer never started its entry";
  ASSERT_TRUE(WIFSIGNALED(status)) << "the writer finished before it was killed";
  Spool spool({.dir = dir, .max_entries = 0});
  EXPECT_TRUE(spool.Entries().empty());
  int removed = 0;
  ASSERT_EQ(spool.Recover(&removed), "");
  EXPECT_EQ(removed, 1);
  EXPECT_TRUE(fs::is_empty(dir));
}

// A write that fails half-way (here: the file size limit, as a full disk would) is reported
// with the file name and leaves earlier entries intact.
TEST(Spool, FailedWriteIsReportedAndEarlierEntriesSurvive) {
  const fs::path dir = FreshDir("full");
  Spool spool({.dir = dir, .max_entries = 0});
  ASSERT_EQ(spool.Recover(), "");
  ASSERT_TRUE(spool.Commit({{"a", "first"}}, 0).ok);
  const pid_t child = ::fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    ::signal(SIGXFSZ, SIG_IGN);
    rlimit limit{4096, 4096};
    ::setrlimit(RLIMIT_FSIZE, &limit);
    const SpoolCommit c = spool.Commit({{"small", "x"}, {"big.obj", std::string(8192, 'y')}}, 0);
    const bool reported = !c.ok && c.error.find("big.obj") != std::string::npos;
    ::_exit(reported ? 0 : 1);
  }
  int status = 0;
  ::waitpid(child, &status, 0);
  ASSERT_TRUE(WIFEXITED(status));
  EXPECT_EQ(WEXITSTATUS(status), 0) << "the failed write was not reported with the file name";
  const auto entries = spool.Entries();
  ASSERT_EQ(entries.size(), 1u);
  EXPECT_EQ(ReadFile(entries[0] / "a"), "first");
  // The entry and `latest`, which still names it.
  EXPECT_EQ(std::distance(fs::directory_iterator(dir), fs::directory_iterator()), 2);
  EXPECT_EQ(fs::read_symlink(dir / "latest"), entries[0].filename());
}

}  // namespace
}  // namespace mm
