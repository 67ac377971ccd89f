#pragma once
// Hooks: programs the daemon runs after a capture ([hooks] on_entry with the entry's folder,
// on_failure with the reason), for integrations that want a push instead of watching the
// spool. A hook runs without a shell, in its own process group, stdin /dev/null and stdout to
// the daemon's stderr (the journal), with a time limit; starting it never waits, and its end
// is collected later (Reap, on SIGCHLD), so a hook that hangs or fails cannot delay the next
// capture. At the limit the whole group is killed (a shell's children too).

#include <sys/types.h>

#include <chrono>
#include <string>
#include <vector>

namespace mm {

struct HookOptions {
  std::vector<std::string> on_entry = {};    ///< argv; the entry's folder is appended. Empty: none.
  std::vector<std::string> on_failure = {};  ///< argv; the failure's reason is appended.
  double timeout_s = 30.0;                   ///< A hook still running then is killed (SIGKILL).
  int max_running = 4;                       ///< Beyond this many running, a hook is skipped.
};

/// The words of a [hooks] command: split at spaces and tabs, no quoting, no shell (a command
/// needing either is a script). Empty for an empty or blank command.
std::vector<std::string> SplitHookCommand(const std::string& command);

/// How a hook ended.
struct HookEnd {
  std::string name;  ///< "on_entry" or "on_failure".
  pid_t pid = -1;
  std::string how;  ///< DescribeWaitStatus: "exited 0", "killed by signal 9 (Killed)".
  bool ok = false;  ///< Exited 0.
  bool timed_out = false;
  double seconds = 0;
};

/// What starting a hook did: nothing (no hook configured: message empty), started it, or not
/// (the message says why: the running cap, a program that cannot start).
struct HookStart {
  bool started = false;
  std::string message;
};

class HookRunner {
 public:
  using Clock = std::chrono::steady_clock;

  explicit HookRunner(HookOptions options) : options_(std::move(options)) {}
  /// Kills the hooks still running (their process groups) and reaps them.
  ~HookRunner();
  HookRunner(const HookRunner&) = delete;
  HookRunner& operator=(const HookRunner&) = delete;

  /// Starts on_entry with `entry_dir` (nothing when unset); the caller logs the message.
  HookStart OnEntry(const std::string& entry_dir, uint64_t capture);
  /// Starts on_failure with `reason`.
  HookStart OnFailure(const std::string& reason, uint64_t capture);

  /// Collects the hooks that ended (never blocks).
  std::vector<HookEnd> Reap();
  /// Kills the process group of every hook past its time limit; Reap reports them.
  void KillOverdue(Clock::time_point now = Clock::now());

  [[nodiscard]] size_t running() const { return running_.size(); }

 private:
  struct Running {
    std::string name;
    pid_t pid = -1;
    Clock::time_point started;
    bool killed = false;
  };
  HookStart Start(const char* name, const std::vector<std::string>& command,
                  const std::string& argument, uint64_t capture, const std::string& env_name);

  HookOptions options_;
  std::vector<Running> running_;
};

}  // namespace mm
