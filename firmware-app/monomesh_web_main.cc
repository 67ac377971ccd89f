// monomesh-web: the operator's web page and JSON API (docs/web.md). Wiring only: the command
// line, the config's [web], [spool] and [control] keys, the token, the server
// (web/web_server.h) on the control socket (app/web_link.h), until SIGTERM or SIGINT.

#include <signal.h>
#include <systemd/sd-daemon.h>

#include <spdlog/spdlog.h>
#include <CLI/CLI.hpp>
#include <thread>

#include "app/config.h"
#include "app/logging.h"
#include "app/web_link.h"
#include "base/text_file.h"
#include "base/version.h"
#include "web/web_server.h"

namespace {

// The token file's first line without surrounding white space, or "" with *error.
std::string ReadToken(const std::filesystem::path& file, std::string* error) {
  const std::optional<std::string> text = mm::ReadTextFile(file, 4096, error);
  if (!text) return {};
  const size_t begin = text->find_first_not_of(" \t\r\n");
  const size_t end = text->find_first_of("\r\n", begin == std::string::npos ? 0 : begin);
  std::string token = begin == std::string::npos ? std::string() : text->substr(begin, end - begin);
  while (!token.empty() && (token.back() == ' ' || token.back() == '\t')) token.pop_back();
  if (token.size() < 16) {
    *error = file.string() + ": the token must be at least 16 characters on the first line";
    return {};
  }
  return token;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"monomesh-web: the monomesh appliance's web page and JSON API"};
  app.set_version_flag("-V,--version", std::string("monomesh-web ") + mm::kMonomeshVersion);
  std::string config_path = "/etc/monomesh/monomeshd.toml";
  app.add_option("-c,--config", config_path,
                 "The daemon's config file (TOML): [web], [spool], [control]")
      ->capture_default_str();
  CLI11_PARSE(app, argc, argv);

  // Exit codes as monomeshd's (docs/exit_codes.md): 78 config, 69 address unavailable.
  mm::DaemonConfig config;
  if (const int code = mm::LoadConfigAndSetupLogging(config_path, &config); code != 0) return code;
  std::string error;
  const std::string token = ReadToken(config.web.token_file, &error);
  if (token.empty()) {
    spdlog::critical("config: key 'web.token_file': {}", error);
    return 78;
  }

  // Signals are read by this thread only (sigwait); every thread started below inherits the mask.
  sigset_t signals;
  sigemptyset(&signals);
  sigaddset(&signals, SIGTERM);
  sigaddset(&signals, SIGINT);
  pthread_sigmask(SIG_BLOCK, &signals, nullptr);
  signal(SIGPIPE, SIG_IGN);

  mm::ControlSocketLink link(config.control_socket);
  mm::WebServerOptions options;
  options.host = config.web.listen_host;
  options.port = config.web.listen_port;
  options.spool_dir = config.spool_dir;
  options.static_dir = config.web.static_dir;
  options.three_dir = config.web.three_dir;
  options.token = token;
  mm::WebServer server(options, link);
  if (const std::string problem = server.Bind(); !problem.empty()) {
    spdlog::critical("web: {}", problem);
    return 69;
  }
  spdlog::info("monomesh-web {} on http://{}:{}/ (spool {}, daemon {})", mm::kMonomeshVersion,
               options.host, server.port(), options.spool_dir.string(),
               config.control_socket.string());
  std::thread listener([&server] { server.Listen(); });
  sd_notify(0, "READY=1");
  int signal_number = 0;
  sigwait(&signals, &signal_number);
  sd_notify(0, "STOPPING=1");
  spdlog::info("web: stopping ({})", strsignal(signal_number));
  server.Stop();
  listener.join();
  return 0;
}
