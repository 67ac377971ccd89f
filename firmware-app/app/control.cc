#include "app/control.h"

#include <grp.h>
#include <poll.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>

#include <cerrno>
#include <cstring>
#include <vector>

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

// The gid of a group name. \throws ControlAccessError naming the key.
gid_t GroupId(const std::string& name) {
  group entry{};
  group* found = nullptr;
  std::vector<char> buf(16384);
  int err = 0;
  while ((err = ::getgrnam_r(name.c_str(), &entry, buf.data(), buf.size(), &found)) == ERANGE) {
    buf.resize(buf.size() * 2);
  }
  if (found == nullptr) {
    throw ControlAccessError("control.group: no group '" + name + "'" +
                             (err != 0 ? std::string(": ") + std::strerror(err) : std::string()) +
                             " (set [control] group to an existing group, or \"\" for the "
                             "daemon's own)");
  }
  return entry.gr_gid;
}

// Gives the freshly bound socket file its group (-1: unchanged) and mode, before listen: nobody
// can connect yet.
void ApplyAccess(const std::filesystem::path& path, const ControlSocketAccess& access, gid_t gid) {
  if (gid != static_cast<gid_t>(-1)) {
    if (::lchown(path.c_str(), static_cast<uid_t>(-1), gid) != 0) {
      throw ControlAccessError("control.group: control socket " + path.string() +
                               ": cannot give it to group '" + access.group + "': " +
                               std::strerror(errno) + " (the daemon's user must be in the group)");
    }
  }
  if (::chmod(path.c_str(), static_cast<mode_t>(access.mode)) != 0) {
    throw ControlAccessError("control.mode: control socket " + path.string() +
                             ": chmod: " + std::strerror(errno));
  }
}

}  // namespace

bool GroupExists(const std::string& name) {
  group entry{};
  group* found = nullptr;
  std::vector<char> buf(16384);
  while (::getgrnam_r(name.c_str(), &entry, buf.data(), buf.size(), &found) == ERANGE) {
    buf.resize(buf.size() * 2);
  }
  return found != nullptr;
}

UniqueFd ListenControlSocket(const std::filesystem::path& path, const ControlSocketAccess& access) {
  const sockaddr_un addr = Address(path);
  const gid_t gid = access.group.empty() ? static_cast<gid_t>(-1) : GroupId(access.group);
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
  try {
    ApplyAccess(path, access, gid);
  } catch (const ControlAccessError&) {
    ::unlink(path.c_str());  // The file this call just bound.
    throw;
  }
  if (::listen(fd.get(), 16) != 0) throw ControlError(Errno(path, "listen"));
  return fd;
}

namespace {

// A status line is a few KiB: whatever streams more without an end of line is no daemon.
constexpr size_t kMaxReplyBytes = size_t{1} << 20;

// Connects to the daemon and sends one request line.
UniqueFd ConnectAndSend(const std::filesystem::path& path, const std::string& command) {
  const sockaddr_un addr = Address(path);
  UniqueFd fd(::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0));
  if (!fd.valid()) throw ControlError(Errno(path, "socket"));
  if (::connect(fd.get(), reinterpret_cast<const sockaddr*>(&addr), sizeof(addr)) != 0) {
    throw ControlError(Errno(path, "connect (is monomeshd running?)"));
  }
  const std::string line = command + "\n";
  if (::send(fd.get(), line.data(), line.size(), MSG_NOSIGNAL) !=
      static_cast<ssize_t>(line.size())) {
    throw ControlError(Errno(path, "send"));
  }
  return fd;
}

// Reads until `pending` holds a whole line or the daemon closes; false when it closed first.
// A negative timeout waits without limit.
bool ReadLine(int fd, const std::filesystem::path& path, std::chrono::milliseconds timeout,
              std::string* pending) {
  char buf[4096];
  while (pending->find('\n') == std::string::npos) {
    pollfd p{fd, POLLIN, 0};
    const int ready = ::poll(&p, 1, static_cast<int>(timeout.count()));
    if (ready == 0) throw ControlTimeout("control socket " + path.string() + ": no reply in time");
    if (ready < 0) {
      if (errno == EINTR) continue;
      throw ControlError(Errno(path, "poll"));
    }
    const ssize_t n = ::recv(fd, buf, sizeof(buf), 0);
    if (n < 0) {
      if (errno == EINTR) continue;
      throw ControlError(Errno(path, "recv"));
    }
    if (n == 0) return false;
    pending->append(buf, static_cast<size_t>(n));
    if (pending->size() > kMaxReplyBytes && pending->find('\n') == std::string::npos) {
      throw ControlError("control socket " + path.string() + ": reply longer than " +
                         std::to_string(kMaxReplyBytes) + " bytes without an end of line");
    }
  }
  return true;
}

}  // namespace

std::string SendControlCommand(const std::filesystem::path& path, const std::string& command,
                               std::chrono::milliseconds timeout) {
  const UniqueFd fd = ConnectAndSend(path, command);
  std::string reply;
  ReadLine(fd.get(), path, timeout, &reply);
  if (const auto nl = reply.find('\n'); nl != std::string::npos) reply.resize(nl);
  return reply;
}

void WatchControlEvents(const std::filesystem::path& path,
                        const std::function<bool(const std::string& line)>& on_line,
                        const std::function<bool()>& keep_watching) {
  const UniqueFd fd = ConnectAndSend(path, "watch");
  std::string pending;
  for (;;) {
    // Without keep_watching the read waits without limit, and times out never.
    bool whole = false;
    try {
      whole =
          ReadLine(fd.get(), path, std::chrono::milliseconds(keep_watching ? 250 : -1), &pending);
    } catch (const ControlTimeout&) {
      if (!keep_watching()) return;
      continue;  // ReadLine keeps what it read so far in `pending`.
    }
    size_t start = 0;
    for (size_t nl = pending.find('\n'); nl != std::string::npos; nl = pending.find('\n', start)) {
      if (!on_line(pending.substr(start, nl - start))) return;
      start = nl + 1;
    }
    pending.erase(0, start);
    if (!whole) return;  // The daemon closed (stopped, or dropped a watcher that fell behind).
  }
}

}  // namespace mm
