#include "app/hooks.h"

#include <signal.h>
#include <sys/wait.h>

#include <cerrno>

#include "base/process.h"

namespace mm {

std::vector<std::string> SplitHookCommand(const std::string& command) {
  std::vector<std::string> words;
  std::string word;
  for (const char c : command) {
    if (c == ' ' || c == '\t') {
      if (!word.empty()) words.push_back(std::move(word));
      word.clear();
    } else {
      word += c;
    }
  }
  if (!word.empty()) words.push_back(std::move(word));
  return words;
}

HookRunner::~HookRunner() {
  for (const Running& r : running_) ::kill(-r.pid, SIGKILL);
  for (const Running& r : running_) {
    while (::waitpid(r.pid, nullptr, 0) < 0 && errno == EINTR) {
    }
  }
}

HookStart HookRunner::OnEntry(const std::string& entry_dir, uint64_t capture) {
  return Start("on_entry", options_.on_entry, entry_dir, capture, "MONOMESH_ENTRY");
}

HookStart HookRunner::OnFailure(const std::string& reason, uint64_t capture) {
  return Start("on_failure", options_.on_failure, reason, capture, "MONOMESH_REASON");
}

HookStart HookRunner::Start(const char* name, const std::vector<std::string>& command,
                            const std::string& argument, uint64_t capture,
                            const std::string& env_name) {
  if (command.empty()) return {};
  if (running_.size() >= static_cast<size_t>(options_.max_running)) {
    return {false, std::string("hook ") + name + " not run: " + std::to_string(running_.size()) +
                       " hooks still running"};
  }
  std::vector<std::string> argv = command;
  argv.push_back(argument);
  pid_t pid = -1;
  const SpawnOptions spawn{
      .stdin_null = true,
      .stdout_to_stderr = true,
      .env = {"MONOMESH_HOOK=" + std::string(name), "MONOMESH_CAPTURE=" + std::to_string(capture),
              env_name + "=" + argument}};
  if (std::string error = SpawnProcess(argv, spawn, &pid); !error.empty()) {
    return {false, std::string("hook ") + name + ": " + error};
  }
  running_.push_back({name, pid, Clock::now(), false});
  return {true, std::string("hook ") + name + " started (pid " + std::to_string(pid) + ")"};
}

std::vector<HookEnd> HookRunner::Reap() {
  std::vector<HookEnd> ended;
  for (auto it = running_.begin(); it != running_.end();) {
    // Looked at first without reaping: while the hook is a zombie its pid, which is its
    // group's id, cannot be reused, so what it left running in its group is killed safely.
    siginfo_t info{};
    const int looked =
        ::waitid(P_PID, static_cast<id_t>(it->pid), &info, WEXITED | WNOHANG | WNOWAIT);
    if ((looked == 0 && info.si_pid == 0) || (looked != 0 && errno == EINTR)) {
      ++it;  // Still running (or ask again next time).
      continue;
    }
    int status = 0;
    pid_t r = -1;  // waitid failed (ECHILD: not this process's child any more): lost.
    if (looked == 0) {
      ::kill(-it->pid, SIGKILL);  // What the hook left running in its group ends with it.
      while ((r = ::waitpid(it->pid, &status, 0)) < 0 && errno == EINTR) {
      }
    }
    ended.push_back({.name = it->name,
                     .pid = it->pid,
                     .how = r < 0 ? "lost (waitpid failed)" : DescribeWaitStatus(status),
                     .ok = r > 0 && WIFEXITED(status) && WEXITSTATUS(status) == 0,
                     .timed_out = it->killed,
                     .seconds = std::chrono::duration<double>(Clock::now() - it->started).count()});
    it = running_.erase(it);
  }
  return ended;
}

void HookRunner::KillOverdue(Clock::time_point now) {
  const auto limit = std::chrono::duration<double>(options_.timeout_s);
  for (Running& r : running_) {
    if (!r.killed && now - r.started >= limit) {
      ::kill(-r.pid, SIGKILL);
      r.killed = true;
    }
  }
}

}  // namespace mm
