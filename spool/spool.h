#pragma once
// The spool: a folder other programs watch. Each capture becomes one entry
// `<spool>/<UTC time>-<seq>/` that appears whole or not at all: its files are written into
// `<spool>/.tmp-<name>/`, each fsynced, the folder fsynced, then renamed into place and the
// spool folder fsynced (rename(2) is atomic within a filesystem). Watchers ignore dot-names.
// Leftovers of a crash (.tmp-<entry name>) are removed by Recover() at start. The spool touches
// only names it makes: entries (`YYYYMMDDThhmmssZ-NNNNNN`, real folders), its .tmp- work
// folders and the symlink `latest`; anything else in the folder is left alone and never counts
// as an entry.
//
// `latest` is a symlink to the newest entry's name (relative, so it resolves wherever the spool
// is mounted), replaced atomically after each commit: a symlink made as `.tmp-latest`, then
// renamed over `latest`. A `latest` that is not a symlink is not the spool's and stays.
//
// Thread-safety: thread-bound (one writer per spool folder).

#include <cstdint>
#include <ctime>
#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

namespace mm {

struct SpoolFile {
  std::string name;   ///< File name inside the entry (no folders).
  std::string bytes;  ///< Content.
};

struct SpoolOptions {
  std::filesystem::path dir;  ///< The spool folder (created if missing).
  int max_entries = 0;        ///< Keep at most this many entries, oldest removed first; 0 = all.
                              ///< Only entries count; foreign files and folders stay.
  [[nodiscard]] std::string Check() const;
};

struct SpoolCommit {
  bool ok = false;
  std::filesystem::path entry;  ///< The final entry folder when ok.
  std::string error;            ///< What failed (names the file and the errno text); with ok,
                      ///< what went wrong after the entry was in place (its fsync, `latest`).
  uint64_t bytes = 0;
  int removed_by_retention = 0;
};

class Spool {
 public:
  explicit Spool(SpoolOptions options);

  /// Creates the spool folder and removes leftovers of an interrupted write. Returns an empty
  /// string or a message naming the folder and the error; `*path_unusable` then says whether
  /// a file stands where the folder (or a parent) must be, which no retry mends.
  [[nodiscard]] std::string Recover(int* removed_leftovers = nullptr,
                                    bool* path_unusable = nullptr);

  /// Writes an entry named `<UTC time of when>-<next sequence>` atomically. On failure
  /// (e.g. ENOSPC) the temporary folder is removed and earlier entries are untouched.
  [[nodiscard]] SpoolCommit Commit(const std::vector<SpoolFile>& files, std::time_t when);

  /// Committed entries (folders with the entry name pattern), oldest first.
  [[nodiscard]] std::vector<std::filesystem::path> Entries() const;
  [[nodiscard]] const std::filesystem::path& dir() const { return options_.dir; }

  static constexpr const char* kTempPrefix = ".tmp-";
  static constexpr const char* kLatestName = "latest";

 private:
  SpoolOptions options_;
  uint64_t next_sequence_ = 1;
};

/// Whether `name` is an entry's name (`YYYYMMDDThhmmssZ-NNNNNN`, what Commit makes).
[[nodiscard]] bool IsSpoolEntryName(std::string_view name);

/// The committed entries in the spool folder `dir` (real folders with an entry's name), oldest
/// first; none when the folder cannot be read. For readers of a spool: nothing is changed.
[[nodiscard]] std::vector<std::filesystem::path> ListSpoolEntries(const std::filesystem::path& dir);

}  // namespace mm
