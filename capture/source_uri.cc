#include "capture/source_uri.h"

#include <charconv>
#include <filesystem>
#include <map>

#include "capture/libcamera_source.h"
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

template <typename T>
T ParseNumber(const std::string& uri, const std::string& key, const std::string& v, T lo, T hi) {
  T out{};
  const auto r = std::from_chars(v.data(), v.data() + v.size(), out);
  if (r.ec != std::errc() || r.ptr != v.data() + v.size() || out < lo || out > hi) {
    throw SourceUriError("camera URI '" + uri + "': " + key + "=" + v + " (expected a number in " +
                         std::to_string(lo) + ".." + std::to_string(hi) + ")");
  }
  return out;
}

}  // namespace

V4l2Options ParseV4l2Uri(const std::string& uri) {
  ParsedUri p = Parse(uri);
  if (p.scheme != "v4l2") throw SourceUriError("camera URI '" + uri + "': not a v4l2: URI");
  if (p.path.empty()) {
    throw SourceUriError("camera URI '" + uri + "': v4l2 needs a device, e.g. v4l2:/dev/video0");
  }
  V4l2Options o;
  o.device = p.path;
  for (const auto& [key, value] : p.params) {
    if (key == "width") {
      o.width = ParseNumber<int>(uri, key, value, 1, 16384);
    } else if (key == "height") {
      o.height = ParseNumber<int>(uri, key, value, 1, 16384);
    } else if (key == "fps") {
      o.fps = ParseNumber<double>(uri, key, value, 0.1, 1000.0);
    } else if (key == "format") {
      o.format = ParsePixelFormat(value);
      if (!o.format) {
        throw SourceUriError("camera URI '" + uri + "': format=" + value +
                             " is not supported (supported: grey, yuyv, nv12, mjpeg, bgr24, rgb24)");
      }
    } else if (key == "gray") {
      o.gray = ParseBool(uri, key, value);
    } else if (key == "exposure") {
      o.exposure = ParseNumber<int>(uri, key, value, 0, 1 << 30);
    } else if (key == "gain") {
      o.gain = ParseNumber<int>(uri, key, value, 0, 1 << 30);
    } else if (key == "buffers") {
      o.buffers = ParseNumber<int>(uri, key, value, 2, 32);
    } else if (key == "timeout_ms") {
      o.lost_after_ms = ParseNumber<int>(uri, key, value, 100, 600000);
    } else {
      throw SourceUriError("camera URI '" + uri + "': unknown parameter '" + key +
                           "' (v4l2 takes width, height, fps, format, gray, exposure, gain, "
                           "buffers, timeout_ms)");
    }
  }
  if ((o.width == 0) != (o.height == 0)) {
    throw SourceUriError("camera URI '" + uri + "': give both width and height");
  }
  return o;
}

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
      } else if (key == "width" || key == "height") {
        int v = 0;
        const auto r = std::from_chars(value.data(), value.data() + value.size(), v);
        if (r.ec != std::errc() || r.ptr != value.data() + value.size() || v <= 0 || v > 16384) {
          throw SourceUriError("camera URI '" + uri + "': " + key + "=" + value +
                               " (expected a size in pixels)");
        }
        (key == "width" ? options.width : options.height) = v;
      } else {
        throw SourceUriError("camera URI '" + uri + "': unknown parameter '" + key +
                             "' (replay takes rate, speed, loop, gray, list, width, height)");
      }
    }
    if ((options.width > 0) != (options.height > 0)) {
      throw SourceUriError("camera URI '" + uri + "': give both width and height, or neither");
    }
    std::filesystem::path folder(p.path);
    if (folder.is_relative()) folder = std::filesystem::path(base_dir) / folder;
    return std::make_unique<ReplaySource>(folder.lexically_normal(), options);
  }
  if (p.scheme == "v4l2") return std::make_unique<V4l2Source>(ParseV4l2Uri(uri));
  if (p.scheme == "libcamera") {
    if (p.path.empty()) {
      throw SourceUriError("camera URI '" + uri + "': libcamera needs a camera id or index, e.g. libcamera:0");
    }
    LibcameraOptions o;
    o.camera = p.path;
    for (const auto& [key, value] : p.params) {
      if (key == "width") {
        o.width = ParseNumber<int>(uri, key, value, 1, 16384);
      } else if (key == "height") {
        o.height = ParseNumber<int>(uri, key, value, 1, 16384);
      } else if (key == "format") {
        o.format = ParsePixelFormat(value);
        if (!o.format) throw SourceUriError("camera URI '" + uri + "': format=" + value + " is not supported");
      } else if (key == "gray") {
        o.gray = ParseBool(uri, key, value);
      } else if (key == "timeout_ms") {
        o.lost_after_ms = ParseNumber<int>(uri, key, value, 100, 600000);
      } else {
        throw SourceUriError("camera URI '" + uri + "': unknown parameter '" + key +
                             "' (libcamera takes width, height, format, gray, timeout_ms)");
      }
    }
    if ((o.width == 0) != (o.height == 0)) {
      throw SourceUriError("camera URI '" + uri + "': give both width and height");
    }
    return std::make_unique<LibcameraSource>(o);
  }
  throw SourceUriError("camera URI '" + uri + "': unknown scheme '" + p.scheme +
                       "' (this build supports: replay, v4l2, libcamera)");
}

}  // namespace mm
