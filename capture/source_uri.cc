#include "capture/source_uri.h"

#include <map>

#include "capture/v4l2_source.h"

namespace mm {
namespace {

std::map<std::string, FrameSourceFactory>& Registry() {
  static std::map<std::string, FrameSourceFactory> registry;
  return registry;
}

}  // namespace

SourceUri ParseSourceUri(const std::string& uri) {
  SourceUri out;
  out.text = uri;
  const auto colon = uri.find(':');
  if (colon == std::string::npos || colon == 0) {
    throw SourceUriError("camera URI '" + uri + "': expected <scheme>:<target>[?key=value&...]");
  }
  out.scheme = uri.substr(0, colon);
  std::string rest = uri.substr(colon + 1);
  const auto q = rest.find('?');
  out.target = rest.substr(0, q);
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

bool UriBool(const SourceUri& uri, const std::string& key, const std::string& v) {
  if (v == "1" || v == "true" || v == "yes") return true;
  if (v == "0" || v == "false" || v == "no") return false;
  throw SourceUriError("camera URI '" + uri.text + "': " + key + "=" + v + " is not 0 or 1");
}

bool RegisterFrameSource(const std::string& scheme, FrameSourceFactory factory) {
  if (!Registry().emplace(scheme, factory).second) {
    throw std::logic_error("frame source scheme '" + scheme + "' registered twice");
  }
  return true;
}

std::vector<std::string> FrameSourceSchemes() {
  std::vector<std::string> out;
  for (const auto& [scheme, factory] : Registry()) out.push_back(scheme);
  return out;
}

V4l2Options ParseV4l2Uri(const std::string& uri) {
  const SourceUri p = ParseSourceUri(uri);
  if (p.scheme != "v4l2") throw SourceUriError("camera URI '" + uri + "': not a v4l2: URI");
  if (p.target.empty()) {
    throw SourceUriError("camera URI '" + uri + "': v4l2 needs a device, e.g. v4l2:/dev/video0");
  }
  V4l2Options o;
  o.device = p.target;
  for (const auto& [key, value] : p.params) {
    if (key == "width") {
      o.width = UriNumber<int>(p, key, value, 1, 16384);
    } else if (key == "height") {
      o.height = UriNumber<int>(p, key, value, 1, 16384);
    } else if (key == "fps") {
      o.fps = UriNumber<double>(p, key, value, 0.1, 1000.0);
    } else if (key == "format") {
      o.format = ParsePixelFormat(value);
      if (!o.format) {
        throw SourceUriError("camera URI '" + uri + "': format=" + value +
                             " is not supported (supported: grey, yuyv, nv12, mjpeg, bgr24, rgb24)");
      }
    } else if (key == "gray") {
      o.gray = UriBool(p, key, value);
    } else if (key == "exposure") {
      o.exposure = UriNumber<int>(p, key, value, 0, 1 << 30);
    } else if (key == "gain") {
      o.gain = UriNumber<int>(p, key, value, 0, 1 << 30);
    } else if (key == "buffers") {
      o.buffers = UriNumber<int>(p, key, value, 2, 32);
    } else if (key == "timeout_ms") {
      o.lost_after_ms = UriNumber<int>(p, key, value, 100, 600000);
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
  const SourceUri p = ParseSourceUri(uri);
  const auto it = Registry().find(p.scheme);
  if (it == Registry().end()) {
    std::string known;
    for (const std::string& scheme : FrameSourceSchemes()) {
      known += (known.empty() ? "" : ", ") + scheme;
    }
    throw SourceUriError("camera URI '" + uri + "': unknown scheme '" + p.scheme +
                         "' (this build supports: " + known + ")");
  }
  return it->second(p, base_dir);
}

namespace {

std::unique_ptr<FrameSource> MakeV4l2Source(const SourceUri& uri, const std::string&) {
  return std::make_unique<V4l2Source>(ParseV4l2Uri(uri.text));
}

}  // namespace

MM_REGISTER_FRAME_SOURCE(v4l2, MakeV4l2Source);

}  // namespace mm
