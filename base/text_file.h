#pragma once
// Reads a whole file the appliance was pointed at (a config, a calibration, a list, a report):
// a regular file of bounded size, so a FIFO, a device (/dev/zero) or a runaway file can neither
// hang the reader nor exhaust the board's memory. Errors name the path.
//
// Thread-safety: reentrant.

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <optional>
#include <string>

#include "base/unique_fd.h"

namespace mm {

/// The file's bytes, or nullopt with `*error` = "<path>: cannot open for reading: <reason>",
/// "<path>: not a regular file" or "<path>: larger than <max_bytes> bytes".
inline std::optional<std::string> ReadTextFile(const std::filesystem::path& path, size_t max_bytes,
                                               std::string* error) {
  // O_NONBLOCK: opening a FIFO without a writer returns at once instead of waiting for one.
  UniqueFd fd(::open(path.c_str(), O_RDONLY | O_CLOEXEC | O_NONBLOCK | O_NOCTTY));
  if (!fd.valid()) {
    *error = path.string() + ": cannot open for reading: " + std::strerror(errno);
    return std::nullopt;
  }
  struct stat st {};
  if (::fstat(fd.get(), &st) != 0 || !S_ISREG(st.st_mode)) {
    *error = path.string() + ": not a regular file";
    return std::nullopt;
  }
  std::string text;
  char buf[65536];
  for (;;) {
    const ssize_t n = ::read(fd.get(), buf, sizeof(buf));
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) {
      *error = path.string() + ": read error: " + std::strerror(errno);
      return std::nullopt;
    }
    if (n == 0) return text;
    if (text.size() + static_cast<size_t>(n) > max_bytes) {
      *error = path.string() + ": larger than " + std::to_string(max_bytes) + " bytes";
      return std::nullopt;
    }
    text.append(buf, static_cast<size_t>(n));
  }
}

/// Upper bounds of what the appliance reads whole: far above any real file, far below a
/// board's memory.
inline constexpr size_t kMaxConfigFileBytes = size_t{1} << 20;  ///< monomeshd.toml
inline constexpr size_t kMaxDataFileBytes = size_t{256} << 20;  ///< Calibrations, lists, logs.

}  // namespace mm
