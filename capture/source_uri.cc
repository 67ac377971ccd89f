#include "capture/source_uri.h"

#include <charconv>
#include <filesystem>
#include <map>

#include "capture/replay_source.h"

namespace mm {
namespace {

struct ParsedUri {
  std::string scheme;
  std::string path;
  std::map<std::string, std::string> params;
};

ParsedUri Parse(const std::string& uri) {
  ParsedUri out;
  const auto colon = uri.find(':');
  if (colon == std::string::npos || colon == 0) {
    throw SourceUriError("camera URI '" + uri + "': expected <scheme>:<target>[?key=value&...]");
  }
  out.scheme = uri.substr(0, colon);
  std::string rest = uri.substr(colon + 1);
  const auto q = rest.find('?');
  out.path = rest.substr(0, q);
  if (q != std::string::npos) {
    std::string query = rest.substr(q + 1);
    size_t start = 0;
    while (start <= query.size()) {
      const size_t amp = std::min(query.find('&', start), query.size());
      const std::string kv = query.substr(start, amp - start);
      if (!kv.empty()) {
        const auto eq = kv.find('=');
        if (eq == std::string::npos) {
          throw SourceUriError("camera URI '" + uri + "': parameter '" + kv + "' has no value");
        }
        out.params[kv.substr(0, eq)] = kv.substr(eq + 1);
      }
      start = amp + 1;
    }
  }
  return out;
}

bool ParseBool(const std::string& uri, const std::string& key, const std::string& v) {
  if (v == "1" || v == "true" || v == "yes") return true;
  if (v == "0" || v == "false" || v == "no") return false;
  throw SourceUriError("camera URI '" + uri + "': " + key + "=" + v + " is not 0 or 1");
}

}  // namespace

std::unique_ptr<FrameSource> CreateFrameSource(const std::string& uri, const std::string& base_dir) {
  ParsedUri p = Parse(uri);
  if (p.scheme == "replay") {
    if (p.path.empty()) throw SourceUriError("camera URI '" + uri + "': replay needs a folder");
    ReplayOptions options;
    for (const auto& [key, value] : p.params) {
      if (key == "rate") {
        if (value != "realtime" && value != "max") {
          throw SourceUriError("camera URI '" + uri + "': rate=" + value +
                               " (expected realtime or max)");
        }
        options.realtime = value == "realtime";
      } else if (key == "speed") {
        const auto r = std::from_chars(value.data(), value.data() + value.size(), options.speed);
        if (r.ec != std::errc() || r.ptr != value.data() + value.size() || !(options.speed > 0)) {
          throw SourceUriError("camera URI '" + uri + "': speed=" + value +
                               " (expected a number > 0)");
        }
      } else if (key == "loop") {
        options.loop = ParseBool(uri, key, value);
      } else if (key == "gray") {
        options.gray = ParseBool(uri, key, value);
      } else if (key == "list") {
        options.list = value;
      } else {
        throw SourceUriError("camera URI '" + uri + "': unknown parameter '" + key +
                             "' (replay takes rate, speed, loop, gray, list)");
      }
    }
    std::filesystem::path folder(p.path);
    if (folder.is_relative()) folder = std::filesystem::path(base_dir) / folder;
    return std::make_unique<ReplaySource>(folder.lexically_normal(), options);
  }
  throw SourceUriError("camera URI '" + uri + "': unknown scheme '" + p.scheme +
                       "' (this build supports: replay)");
}

}  // namespace mm
