#pragma once
// Child processes the daemon starts (the libcamera worker, the hooks): posix_spawn into a
// process group of their own, with no signal blocked and the signals the daemon reads
// through signalfd back at their defaults (a spawned child inherits the blocked mask, and a
// child with SIGTERM blocked cannot be stopped), and the wait status in words.

#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstring>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

extern char** environ;  // NOLINT(readability-redundant-declaration): POSIX leaves it undeclared.

namespace mm {

struct SpawnOptions {
  /// (from, to): the child's descriptor `to` is the parent's `from`.
  std::vector<std::pair<int, int>> dup2 = {};
  bool stdin_null = false;            ///< The child's stdin reads /dev/null.
  bool stdout_to_stderr = false;      ///< The child's stdout is the parent's stderr (the journal).
  std::vector<std::string> env = {};  ///< "NAME=value" added to the parent's environment.
};

/// Starts `argv` (argv[0] a path; no shell, no PATH search) in its own process group, so
/// kill(-pid, ...) reaches whatever it starts in turn. Returns an error naming the program, or
/// "" with *pid set. An argv[0] that is not executable is refused here: a failed exec is not
/// reported by posix_spawn everywhere (qemu-user: exit 127).
inline std::string SpawnProcess(const std::vector<std::string>& argv, const SpawnOptions& options,
                                pid_t* pid) {
  if (argv.empty() || argv[0].empty()) return "no program to start";
  if (::access(argv[0].c_str(), X_OK) != 0) {
    return "cannot start " + argv[0] + ": " + std::strerror(errno);
  }
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  if (options.stdin_null) posix_spawn_file_actions_addopen(&actions, 0, "/dev/null", O_RDONLY, 0);
  if (options.stdout_to_stderr) posix_spawn_file_actions_adddup2(&actions, 2, 1);
  for (const auto& [from, to] : options.dup2) posix_spawn_file_actions_adddup2(&actions, from, to);
  posix_spawnattr_t attr;
  posix_spawnattr_init(&attr);
  sigset_t none, defaults;
  sigemptyset(&none);
  sigemptyset(&defaults);
  for (int sig : {SIGINT, SIGTERM, SIGHUP, SIGUSR1, SIGUSR2, SIGCHLD, SIGPIPE}) {
    sigaddset(&defaults, sig);
  }
  posix_spawnattr_setsigmask(&attr, &none);
  posix_spawnattr_setsigdefault(&attr, &defaults);
  posix_spawnattr_setpgroup(&attr, 0);
  posix_spawnattr_setflags(&attr,
                           POSIX_SPAWN_SETSIGMASK | POSIX_SPAWN_SETSIGDEF | POSIX_SPAWN_SETPGROUP);
  std::vector<char*> args;
  for (const std::string& a : argv) args.push_back(const_cast<char*>(a.c_str()));
  args.push_back(nullptr);
  std::vector<char*> env;
  for (char** e = environ; e != nullptr && *e != nullptr; ++e) {
    const std::string_view entry(*e);
    const std::string_view name = entry.substr(0, entry.find('=') + 1);
    bool replaced = false;
    for (const std::string& o : options.env) replaced = replaced || o.starts_with(name);
    if (!replaced) env.push_back(*e);
  }
  for (const std::string& e : options.env) env.push_back(const_cast<char*>(e.c_str()));
  env.push_back(nullptr);
  const int r = posix_spawn(pid, argv[0].c_str(), &actions, &attr, args.data(), env.data());
  posix_spawnattr_destroy(&attr);
  posix_spawn_file_actions_destroy(&actions);
  if (r != 0) return "cannot start " + argv[0] + ": " + std::strerror(r);
  return {};
}

/// A waitpid status in words: "exited 3", "killed by signal 9 (Killed)".
inline std::string DescribeWaitStatus(int status) {
  if (WIFEXITED(status)) return "exited " + std::to_string(WEXITSTATUS(status));
  if (WIFSIGNALED(status)) {
    const int s = WTERMSIG(status);
    return "killed by signal " + std::to_string(s) + " (" + strsignal(s) + ")";
  }
  return "ended (status " + std::to_string(status) + ")";
}

}  // namespace mm
