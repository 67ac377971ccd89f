#include "spool/spool.h"

#include "base/unique_fd.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <charconv>
#include <cstdio>
#include <cstring>
#include <string_view>
#include <system_error>

namespace mm {
namespace {

namespace fs = std::filesystem;

// The folder's items, stopping at the first error: a range-for over directory_iterator calls
// operator++, which throws filesystem_error; increment(ec) does not.
std::vector<fs::directory_entry> ListFolder(const fs::path& dir, std::error_code& ec) {
  std::vector<fs::directory_entry> items;
  for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
    items.push_back(*it);
  }
  return items;
}

std::string ErrnoText(int err) { return std::strerror(err); }

// Returns an empty string or "<path>: <what>: <strerror>".
std::string WriteFileDurably(const fs::path& path, const std::string& bytes) {
  UniqueFd fd(::open(path.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0644));
  if (fd.get() < 0) return path.string() + ": create: " + ErrnoText(errno);
  size_t done = 0;
  while (done < bytes.size()) {
    const ssize_t n = ::write(fd.get(), bytes.data() + done, bytes.size() - done);
    if (n < 0) {
      if (errno == EINTR) continue;
      return path.string() + ": write: " + ErrnoText(errno);
    }
    done += static_cast<size_t>(n);
  }
  if (::fsync(fd.get()) != 0) return path.string() + ": fsync: " + ErrnoText(errno);
  if (fd.Close() != 0) return path.string() + ": close: " + ErrnoText(errno);
  return {};
}

std::string FsyncDir(const fs::path& dir) {
  UniqueFd fd(::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC));
  if (fd.get() < 0) return dir.string() + ": open: " + ErrnoText(errno);
  if (::fsync(fd.get()) != 0) return dir.string() + ": fsync: " + ErrnoText(errno);
  return {};
}

bool IsDigits(std::string_view s) {
  return !s.empty() && std::all_of(s.begin(), s.end(), [](char c) { return c >= '0' && c <= '9'; });
}

// The spool owns only what it names: entries "<YYYYMMDDThhmmssZ>-<sequence of >= 6 digits>"
// (what Commit makes) and its work folders, kTempPrefix + an entry name or + "del-" + an entry
// name. Anything else in the folder (an operator's archive/, a watcher's files) is never
// listed, counted for retention or removed.
bool IsEntryName(std::string_view name) {
  return name.size() >= 23 && IsDigits(name.substr(0, 8)) && name[8] == 'T' &&
         IsDigits(name.substr(9, 6)) && name[15] == 'Z' && name[16] == '-' &&
         IsDigits(name.substr(17));
}

constexpr std::string_view kDeletePrefix = "del-";

bool IsOwnWorkName(std::string_view name) {
  const std::string_view temp = Spool::kTempPrefix;
  if (name.substr(0, temp.size()) != temp) return false;
  name.remove_prefix(temp.size());
  if (name == Spool::kLatestName) return true;  // A `latest` being replaced.
  if (name.substr(0, kDeletePrefix.size()) == kDeletePrefix)
    name.remove_prefix(kDeletePrefix.size());
  return IsEntryName(name);
}

// The sequence number after the entry name's '-' (0 when it does not fit in 64 bits).
uint64_t SequenceOf(const std::string& name) {
  uint64_t sequence = 0;
  const char* digits = name.data() + 17;
  std::from_chars(digits, name.data() + name.size(), sequence);
  return sequence;
}

// A real folder, not a symlink to one (the spool never follows links out of itself).
bool IsRealDirectory(const fs::directory_entry& item) {
  std::error_code ec;
  return item.symlink_status(ec).type() == fs::file_type::directory;
}

// Points `latest` at `entry_name`: a new symlink under the work name, renamed over `latest`
// (rename(2) replaces it atomically: a reader sees the old or the new target, never none).
// Returns an empty string or what failed.
std::string UpdateLatest(const fs::path& dir, const std::string& entry_name) {
  const fs::path latest = dir / Spool::kLatestName;
  struct stat st {};
  if (::lstat(latest.c_str(), &st) == 0 && !S_ISLNK(st.st_mode)) {
    return latest.string() + ": not a symlink; left alone";
  }
  const fs::path temp = dir / (std::string(Spool::kTempPrefix) + Spool::kLatestName);
  ::unlink(temp.c_str());  // A leftover of an interrupted update.
  if (::symlink(entry_name.c_str(), temp.c_str()) != 0) {
    return temp.string() + ": symlink: " + ErrnoText(errno);
  }
  if (::rename(temp.c_str(), latest.c_str()) != 0) {
    const std::string error = latest.string() + ": rename: " + ErrnoText(errno);
    ::unlink(temp.c_str());
    return error;
  }
  return {};
}

}  // namespace

std::string SpoolOptions::Check() const {
  if (dir.empty()) return "dir: must name a folder";
  if (max_entries < 0) return "max_entries: must be >= 0";
  return {};
}

Spool::Spool(SpoolOptions options) : options_(std::move(options)) {}

std::string Spool::Recover(int* removed_leftovers, bool* path_unusable) {
  std::error_code ec;
  fs::create_directories(options_.dir, ec);
  if (ec) {
    // A file where the folder or one of its parents should be: no restart makes it a folder.
    if (path_unusable != nullptr) {
      *path_unusable = ec == std::errc::file_exists || ec == std::errc::not_a_directory;
    }
    return "spool " + options_.dir.string() + ": cannot create: " + ec.message();
  }
  int removed = 0;
  uint64_t max_sequence = 0;
  for (const auto& item : ListFolder(options_.dir, ec)) {
    const std::string name = item.path().filename().string();
    if (IsOwnWorkName(name)) {
      // remove_all does not follow a symlink (a leftover .tmp-latest): it removes the link.
      fs::remove_all(item.path(), ec);
      if (ec) return "spool: cannot remove leftover " + item.path().string() + ": " + ec.message();
      ++removed;
    } else if (IsEntryName(name) && IsRealDirectory(item)) {
      max_sequence = std::max(max_sequence, SequenceOf(name));
    }
  }
  if (ec) return "spool " + options_.dir.string() + ": cannot list: " + ec.message();
  next_sequence_ = max_sequence + 1;
  if (removed_leftovers != nullptr) *removed_leftovers = removed;
  return removed > 0 ? FsyncDir(options_.dir) : std::string();
}

std::vector<fs::path> Spool::Entries() const { return ListSpoolEntries(options_.dir); }

bool IsSpoolEntryName(std::string_view name) { return IsEntryName(name); }

std::vector<fs::path> ListSpoolEntries(const fs::path& dir) {
  std::vector<fs::path> entries;
  std::error_code ec;
  for (const auto& item : ListFolder(dir, ec)) {
    if (IsRealDirectory(item) && IsEntryName(item.path().filename().string())) {
      entries.push_back(item.path());
    }
  }
  std::sort(entries.begin(), entries.end(), [](const fs::path& a, const fs::path& b) {
    return SequenceOf(a.filename().string()) < SequenceOf(b.filename().string());
  });
  return entries;
}

SpoolCommit Spool::Commit(const std::vector<SpoolFile>& files, std::time_t when) {
  SpoolCommit result;
  std::tm utc{};
  gmtime_r(&when, &utc);
  char stamp[32];
  std::strftime(stamp, sizeof(stamp), "%Y%m%dT%H%M%SZ", &utc);
  char name[64];
  std::snprintf(name, sizeof(name), "%s-%06llu", stamp,
                static_cast<unsigned long long>(next_sequence_));
  const fs::path temp = options_.dir / (std::string(kTempPrefix) + name);
  const fs::path final_path = options_.dir / name;

  auto fail = [&](std::string error) {
    std::error_code ignored;
    fs::remove_all(temp, ignored);
    result.error = std::move(error);
    return result;
  };

  if (::mkdir(temp.c_str(), 0755) != 0) {
    return fail(temp.string() + ": mkdir: " + ErrnoText(errno));
  }
  for (const SpoolFile& file : files) {
    if (file.name.empty() || file.name.find('/') != std::string::npos || file.name[0] == '.') {
      return fail("spool: invalid entry file name '" + file.name + "'");
    }
    if (std::string error = WriteFileDurably(temp / file.name, file.bytes); !error.empty()) {
      return fail(error);
    }
    result.bytes += file.bytes.size();
  }
  if (std::string error = FsyncDir(temp); !error.empty()) return fail(error);
  if (::rename(temp.c_str(), final_path.c_str()) != 0) {
    return fail(final_path.string() + ": rename: " + ErrnoText(errno));
  }
  ++next_sequence_;
  result.ok = true;
  result.entry = final_path;
  if (std::string error = FsyncDir(options_.dir); !error.empty()) {
    // The entry is complete and visible; only its durability across power loss is in doubt.
    result.error = error;
  }
  if (std::string error = UpdateLatest(options_.dir, name); !error.empty()) {
    result.error += (result.error.empty() ? "" : "; ") + error;
  }

  if (options_.max_entries > 0) {
    auto entries = Entries();
    std::error_code ec;
    for (size_t i = 0; i + static_cast<size_t>(options_.max_entries) < entries.size(); ++i) {
      // Rename out of sight first so a watcher never sees a half-deleted entry.
      const fs::path doomed =
          options_.dir /
          (std::string(kTempPrefix) + std::string(kDeletePrefix) + entries[i].filename().string());
      fs::rename(entries[i], doomed, ec);
      if (!ec) fs::remove_all(doomed, ec);
      if (!ec) ++result.removed_by_retention;
    }
  }
  return result;
}

}  // namespace mm
