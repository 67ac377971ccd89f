#pragma once
// What monomesh-web shows of the spool: each entry's summary (docs/web.md) and its files.
// Names from a request are looked up in the spool's own listing (ListSpoolEntries) and in the
// entry folder's listing; a name is never joined to a path before it is found there, so no
// "..", "/" or encoded form of them reaches the file system.
//
// Thread-safety: reentrant (reads the file system only).

#include <filesystem>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <string_view>

namespace mm {

/// One entry's summary from its report.json (docs/web.md): name, kind ("pair" or "walk"), files,
/// success, failure_reason, time_unix_s, vertices, triangles, points, units; a pair's pair,
/// mesh_mode, inliers, median_triangulation_angle_deg, reprojection_rms_px; a walk's
/// stop_reason, keyframes, registered, segments, walk_seconds; report_error when the report
/// cannot be read.
nlohmann::json EntrySummary(const std::filesystem::path& entry_dir);

/// Every entry of the spool folder, newest first, as {"entries": [summary, ...]}.
nlohmann::json ListEntrySummaries(const std::filesystem::path& spool_dir);

/// The folder of the entry called `name` when the spool lists one.
std::optional<std::filesystem::path> FindEntry(const std::filesystem::path& spool_dir,
                                               std::string_view name);

/// The regular file called `file` in an entry folder, when its listing has one (a symlink or a
/// folder is not an entry's file).
std::optional<std::filesystem::path> FindEntryFile(const std::filesystem::path& entry_dir,
                                                   std::string_view file);

/// mesh.obj, mesh.mtl and texture.jpg of an entry in one zip archive (libzip, deflated), or
/// nullopt with *error naming the file that is missing or unreadable.
std::optional<std::string> ZipObjFiles(const std::filesystem::path& entry_dir, std::string* error);

}  // namespace mm
