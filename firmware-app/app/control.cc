#include "app/control.h"

#include <poll.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>

#include <cerrno>
#include <cstring>

namespace mm {
namespace {

sockaddr_un Address(const std::filesystem::path& path) {
  sockaddr_un addr{};
  addr.sun_family = AF_UNIX;
  const std::string s = path.string();
  if (s.size() >= sizeof(addr.sun_path)) {
    throw ControlPathError("control socket " + s + ": path longer than " +
                       std::to_string(sizeof(addr.sun_path) - 1) + " bytes");
  }
  std::memcpy(addr.sun_path, s.c_str(), s.size() + 1);
  return addr;
}

std::string Errno(const std::filesystem::path& path, const char* what) {
  return "control socket " + path.string() + ": " + what + ": " + std::strerror(errno);
}

}  // namespace

UniqueFd ListenControlSocket(const std::filesystem::path& path) {
  const sockaddr_un addr = Address(path);
  std::error_code ec;
  std::filesystem::create_directories(path.parent_path(), ec);
  // Whatever is at the path is removed only when it is a socket and nobody accepts on it
  // (a config naming /etc/passwd or a folder must not delete it).
  struct stat st {};
  if (::lstat(path.c_str(), &st) == 0) {
    if (!S_ISSOCK(st.st_mode)) {
      throw ControlPathError("control socket " + path.string() +
                             ": exists and is not a socket; not removing it (fix [control] "
                             "socket or move the file away)");
    }
    UniqueFd probe(::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0));
    if (!probe.valid()) throw ControlError(Errno(path, "socket"));
    if (::connect(probe.get(), reinterpret_cast<const sockaddr*>(&addr), sizeof(addr)) == 0) {
      throw ControlError("control socket " + path.string() +
                         ": another monomeshd is listening on it");
    }
    if (errno != ECONNREFUSED) throw ControlError(Errno(path, "connect to the existing socket"));
    if (::unlink(path.c_str()) != 0) throw ControlError(Errno(path, "unlink the stale socket"));
  } else if (errno != ENOENT) {
    throw ControlError(Errno(path, "lstat"));
  }
  UniqueFd fd(::socket(AF_UNIX, SOCK_STREAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0));
  if (!fd.valid()) throw ControlError(Errno(path, "socket"));
  if (::bind(fd.get(), reinterpret_cast<const sockaddr*>(&addr), sizeof(addr)) != 0) {
    throw ControlError(Errno(path, "bind"));
  }
  if (::listen(fd.get(), 16) != 0) throw ControlError(Errno(path, "listen"));
  return fd;
}

std::string SendControlCommand(const std::filesystem::path& path, const std::string& command,
                               std::chrono::milliseconds timeout) {
  const sockaddr_un addr = Address(path);
  UniqueFd fd(::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0));
  if (!fd.valid()) throw ControlError(Errno(path, "socket"));
  if (::connect(fd.get(), reinterpret_cast<const sockaddr*>(&addr), sizeof(addr)) != 0) {
    throw ControlError(Errno(path, "connect (is monomeshd running?)"));
  }
  const std::string line = command + "\n";
  if (::send(fd.get(), line.data(), line.size(), MSG_NOSIGNAL) != static_cast<ssize_t>(line.size())) {
    throw ControlError(Errno(path, "send"));
  }
  std::string reply;
  char buf[4096];
  while (reply.find('\n') == std::string::npos) {
    pollfd p{fd.get(), POLLIN, 0};
    const int ready = ::poll(&p, 1, static_cast<int>(timeout.count()));
    if (ready == 0) throw ControlTimeout("control socket " + path.string() + ": no reply in time");
    if (ready < 0) {
      if (errno == EINTR) continue;
      throw ControlError(Errno(path, "poll"));
    }
    const ssize_t n = ::recv(fd.get(), buf, sizeof(buf), 0);
    if (n < 0) throw ControlError(Errno(path, "recv"));
    if (n == 0) break;
    reply.append(buf, static_cast<size_t>(n));
  }
  if (const auto nl = reply.find('\n'); nl != std::string::npos) reply.resize(nl);
  return reply;
}

}  // namespace mm
