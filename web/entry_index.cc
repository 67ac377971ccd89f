#include "web/entry_index.h"

#include <zip.h>

#include <algorithm>
#include <memory>
#include <system_error>
#include <vector>

#include "base/text_file.h"
#include "entry/entry.h"
#include "entry/report.h"
#include "spool/spool.h"

namespace mm {
namespace fs = std::filesystem;
using json = nlohmann::json;

namespace {

// The entry's regular files by name, sorted.
std::vector<std::string> EntryFiles(const fs::path& entry_dir) {
  std::vector<std::string> files;
  std::error_code ec;
  for (fs::directory_iterator it(entry_dir, ec), end; !ec && it != end; it.increment(ec)) {
    std::error_code status_ec;
    if (fs::is_regular_file(it->symlink_status(status_ec))) {
      files.push_back(it->path().filename().string());
    }
  }
  std::sort(files.begin(), files.end());
  return files;
}

// A capture's wall-clock time in seconds since the epoch, or null when it is unknown (0).
json UnixSecondsOrNull(int64_t realtime_ns) {
  return realtime_ns > 0 ? json(static_cast<double>(realtime_ns) * 1e-9) : json();
}

void PairSummary(const EntryReport& report, json* summary) {
  json& s = *summary;
  s["success"] = report.success;
  s["failure_reason"] = report.failure_reason;
  s["time_unix_s"] = UnixSecondsOrNull(report.keyframe_a.capture_realtime_ns);
  s["pair"] = report.pair_classification.kind;
  s["mesh_mode"] = report.meshing.mode;
  s["vertices"] = report.counts.mesh_vertices;
  s["triangles"] = report.counts.mesh_triangles;
  s["points"] = report.counts.points;
  s["inliers"] = report.counts.inliers;
  s["median_triangulation_angle_deg"] = report.quality.median_triangulation_angle_deg;
  s["reprojection_rms_px"] = report.quality.reprojection_rms_px;
  s["units"] = report.scale.units;
}

void WalkSummary(const WalkReport& report, json* summary) {
  json& s = *summary;
  s["success"] = report.success;
  s["failure_reason"] = report.failure_reason;
  s["time_unix_s"] = UnixSecondsOrNull(
      report.keyframes.empty() ? 0 : report.keyframes.front().info.capture_realtime_ns);
  s["stop_reason"] = report.stop_reason;
  s["keyframes"] = report.counts.keyframes;
  s["registered"] = report.counts.registered;
  s["segments"] = report.counts.segments;
  s["vertices"] = report.counts.mesh_vertices;
  s["triangles"] = report.counts.mesh_triangles;
  s["points"] = report.counts.points;
  s["walk_seconds"] = report.timings_s.walk;
  s["units"] = report.scale.units;
}

}  // namespace

json EntrySummary(const fs::path& entry_dir) {
  json summary{{"name", entry_dir.filename().string()}, {"files", EntryFiles(entry_dir)}};
  // report.json is parsed once and read as the kind it says it is.
  json report_json;
  std::string error = ReadReportJson(entry_dir, &report_json);
  summary["kind"] = error.empty() ? ReportKind(report_json) : "pair";
  if (error.empty()) {
    std::string problem;
    if (summary["kind"] == "walk") {
      WalkReport report;
      problem = FromJson(report_json, &report);
      if (problem.empty()) WalkSummary(report, &summary);
    } else {
      EntryReport report;
      problem = FromJson(report_json, &report);
      if (problem.empty()) PairSummary(report, &summary);
    }
    if (!problem.empty()) error = (entry_dir / "report.json").string() + ": " + problem;
  }
  if (!error.empty()) {
    summary["success"] = false;
    summary["report_error"] = error;
  }
  return summary;
}

json ListEntrySummaries(const fs::path& spool_dir) {
  json entries = json::array();
  const std::vector<fs::path> dirs = ListSpoolEntries(spool_dir);
  for (auto it = dirs.rbegin(); it != dirs.rend(); ++it) entries.push_back(EntrySummary(*it));
  return json{{"entries", std::move(entries)}};
}

std::optional<fs::path> FindEntry(const fs::path& spool_dir, std::string_view name) {
  if (!IsSpoolEntryName(name)) return std::nullopt;
  for (const fs::path& dir : ListSpoolEntries(spool_dir)) {
    if (dir.filename() == name) return dir;
  }
  return std::nullopt;
}

std::optional<fs::path> FindEntryFile(const fs::path& entry_dir, std::string_view file) {
  for (const std::string& name : EntryFiles(entry_dir)) {
    if (name == file) return entry_dir / name;
  }
  return std::nullopt;
}

std::optional<std::string> ZipObjFiles(const fs::path& entry_dir, std::string* error) {
  // The archive is built in a libzip buffer source, kept past zip_close and read back.
  zip_error_t zip_error;
  zip_error_init(&zip_error);
  std::unique_ptr<zip_source_t, decltype(&zip_source_free)> buffer(
      zip_source_buffer_create(nullptr, 0, 0, &zip_error), &zip_source_free);
  if (!buffer) {
    *error = std::string("zip: ") + zip_error_strerror(&zip_error);
    zip_error_fini(&zip_error);
    return std::nullopt;
  }
  zip_source_keep(buffer.get());
  zip_t* archive = zip_open_from_source(buffer.get(), ZIP_TRUNCATE, &zip_error);
  if (archive == nullptr) {
    zip_source_free(buffer.get());  // The reference the archive did not take.
    *error = std::string("zip: ") + zip_error_strerror(&zip_error);
    zip_error_fini(&zip_error);
    return std::nullopt;
  }
  std::vector<std::string> contents;  // libzip reads them at zip_close.
  contents.reserve(3);
  for (const char* name : {"mesh.obj", "mesh.mtl", "texture.jpg"}) {
    const std::optional<fs::path> file = FindEntryFile(entry_dir, name);
    std::optional<std::string> bytes;
    if (file) bytes = ReadTextFile(*file, kMaxDataFileBytes, error);
    if (!bytes) {
      if (!file) *error = (entry_dir / name).string() + ": not in the entry";
      zip_discard(archive);
      return std::nullopt;
    }
    contents.push_back(std::move(*bytes));
    zip_source_t* source =
        zip_source_buffer(archive, contents.back().data(), contents.back().size(), 0);
    if (source == nullptr || zip_file_add(archive, name, source, ZIP_FL_ENC_UTF_8) < 0) {
      if (source != nullptr) zip_source_free(source);
      *error = std::string("zip: ") + zip_strerror(archive);
      zip_discard(archive);
      return std::nullopt;
    }
  }
  if (zip_close(archive) != 0) {
    *error = std::string("zip: ") + zip_strerror(archive);
    zip_discard(archive);
    return std::nullopt;
  }
  std::string out;
  zip_stat_t stat;
  if (zip_source_stat(buffer.get(), &stat) != 0 || zip_source_open(buffer.get()) != 0) {
    *error = "zip: cannot read the archive back";
    return std::nullopt;
  }
  out.resize(stat.size);
  const zip_int64_t n = zip_source_read(buffer.get(), out.data(), stat.size);
  zip_source_close(buffer.get());
  if (n != static_cast<zip_int64_t>(stat.size)) {
    *error = "zip: short read of the archive";
    return std::nullopt;
  }
  return out;
}

}  // namespace mm
