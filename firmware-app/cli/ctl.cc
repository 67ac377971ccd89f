// `monomesh ctl trigger|status|ping|watch|walk start|walk stop|odom T X Y Z [QX QY QZ QW]`: talk to
// a running monomeshd over its control socket.

#include <algorithm>
#include <iostream>
#include <nlohmann/json.hpp>
#include <thread>
#include <vector>

#include "app/config.h"
#include "app/control.h"
#include "cli/commands.h"
#include "entry/json_text.h"

namespace mm::cli {
namespace {

using json = nlohmann::json;

int RunCtl(const std::string& command, const std::filesystem::path& socket, double wait_s) {
  using namespace std::chrono_literals;
  const json reply = json::parse(SendControlCommand(socket, command, 5s));
  if (command != "trigger" || wait_s <= 0 || !reply.value("ok", false)) {
    std::cout << JsonText(reply, 2) << "\n";
    return reply.value("ok", false) ? 0 : 1;
  }
  // Wait until the daemon reports the result of this capture.
  const uint64_t capture = reply["capture"].get<uint64_t>();
  std::cerr << "capture " << capture << " started; waiting up to " << wait_s << " s\n";
  const auto deadline = std::chrono::steady_clock::now() +
                        std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                            std::chrono::duration<double>(wait_s));
  while (std::chrono::steady_clock::now() < deadline) {
    json status;
    try {
      status = json::parse(SendControlCommand(socket, "status", 5s));
    } catch (const ControlTimeout& e) {
      // A daemon busy tracking and reconstructing on a slow machine may answer late: ask
      // again until the deadline (a daemon that is gone fails the connect, which is final).
      std::cerr << "monomesh ctl: " << e.what() << "; asking again\n";
      continue;
    }
    const json& last = status["last_result"];
    if (last.is_object() && last.value("capture", uint64_t{0}) == capture) {
      std::cout << JsonText(last, 2) << "\n";
      return last.value("ok", false) ? 0 : 1;
    }
    std::this_thread::sleep_for(100ms);
  }
  std::cerr << "monomesh ctl: capture " << capture << " did not finish within " << wait_s << " s\n";
  return 1;
}

// Prints the daemon's events, one JSON line each, until the daemon closes the connection or
// an event named in `until` arrives (exit 0; a daemon that closes first exits 1).
int RunWatch(const std::filesystem::path& socket, const std::vector<std::string>& until) {
  bool refused = false, reached = false, first = true;
  WatchControlEvents(socket, [&](const std::string& line) {
    std::cout << line << "\n" << std::flush;
    json event = json::parse(line, nullptr, /*allow_exceptions=*/false);
    if (first) {
      first = false;
      refused = !event.is_object() || !event.value("ok", false);
      return !refused;
    }
    const std::string name = event.is_object() ? event.value("event", "") : "";
    reached = std::find(until.begin(), until.end(), name) != until.end();
    return !reached;
  });
  return refused || (!until.empty() && !reached) ? 1 : 0;
}

}  // namespace

Runner AddCtlCommand(CLI::App& app) {
  auto* cmd = app.add_subcommand("ctl", "Send a command to a running monomeshd");
  struct Args {
    std::string command;
    std::vector<std::string> odom;  // odom's numbers, as given.
    std::string socket = "/run/monomesh/control.sock";
    std::string config;
    double wait_s = 0;
    std::vector<std::string> until;
  };
  auto args = std::make_shared<Args>();
  cmd->add_option("command", args->command, "trigger | status | ping | watch | odom | walk")
      ->required()
      ->check(CLI::IsMember({"trigger", "status", "ping", "watch", "odom", "walk"}));
  cmd->add_option("values", args->odom,
                  "With odom: T X Y Z [QX QY QZ QW] (seconds on [scale] odometry_clock, metres); "
                  "with walk: start | stop")
      ->expected(0, 7);
  auto* socket_option =
      cmd->add_option("--socket", args->socket, "Control socket")->capture_default_str();
  cmd->add_option("--config", args->config, "Take the socket path from this daemon config")
      ->excludes(socket_option);
  cmd->add_option("--wait", args->wait_s,
                  "With trigger: wait up to this many seconds for the result");
  cmd->add_option("--until", args->until,
                  "With watch: stop after the first event of this name (e.g. entry, "
                  "capture_failed; repeatable)");
  AddOptionRules(cmd, {{"--wait", [args] { return args->command == "trigger"; }, "ctl trigger"},
                       {"--until", [args] { return args->command == "watch"; }, "ctl watch"}});
  return [cmd, args]() -> int {
    if (!cmd->parsed()) return -1;
    std::string command = args->command;
    if (command == "odom") {
      if (args->odom.size() != 4 && args->odom.size() != 8) {
        std::cerr << "monomesh ctl odom: expected T X Y Z [QX QY QZ QW], got " << args->odom.size()
                  << " values\n";
        return 2;
      }
      for (const std::string& v : args->odom) command += " " + v;
    } else if (command == "walk") {
      if (args->odom.size() != 1 || (args->odom[0] != "start" && args->odom[0] != "stop")) {
        std::cerr << "monomesh ctl walk: expected start or stop\n";
        return 2;
      }
      command += " " + args->odom[0];
    } else if (!args->odom.empty()) {
      std::cerr << "monomesh ctl " << command << ": takes no values\n";
      return 2;
    }
    const std::filesystem::path socket = args->config.empty()
                                             ? std::filesystem::path(args->socket)
                                             : LoadDaemonConfig(args->config).control_socket;
    if (command == "watch") return RunWatch(socket, args->until);
    return RunCtl(command, socket, args->wait_s);
  };
}

}  // namespace mm::cli
