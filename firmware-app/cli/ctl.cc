// `monomesh ctl trigger|status|ping|odom T X Y Z [QX QY QZ QW]`: talk to a running monomeshd
// over its control socket.

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

int RunCtl(const std::string& command, std::filesystem::path socket, const std::string& config,
           double wait_s) {
  using namespace std::chrono_literals;
  if (!config.empty()) socket = LoadDaemonConfig(config).control_socket;
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

}  // namespace

Runner AddCtlCommand(CLI::App& app) {
  auto* cmd = app.add_subcommand("ctl", "Send a command to a running monomeshd");
  struct Args {
    std::string command;
    std::vector<std::string> odom;  // odom's numbers, as given.
    std::string socket = "/run/monomesh/control.sock";
    std::string config;
    double wait_s = 0;
  };
  auto args = std::make_shared<Args>();
  cmd->add_option("command", args->command, "trigger | status | ping | odom")
      ->required()
      ->check(CLI::IsMember({"trigger", "status", "ping", "odom"}));
  cmd->add_option("values", args->odom,
                  "With odom: T X Y Z [QX QY QZ QW] (seconds on [scale] odometry_clock, metres)")
      ->expected(0, 7);
  cmd->add_option("--socket", args->socket, "Control socket")->capture_default_str();
  cmd->add_option("--config", args->config, "Take the socket path from this daemon config");
  cmd->add_option("--wait", args->wait_s,
                  "With trigger: wait up to this many seconds for the result");
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
    } else if (!args->odom.empty()) {
      std::cerr << "monomesh ctl " << command << ": takes no values\n";
      return 2;
    }
    return RunCtl(command, args->socket, args->config, args->wait_s);
  };
}

}  // namespace mm::cli
