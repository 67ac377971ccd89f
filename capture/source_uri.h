#pragma once
// Frame sources selected by URI, `<scheme>:<target>[?key=value&...]`. Each source registers
// its scheme with a factory (as libcamera registers pipeline handlers); the built-in ones:
//   replay:<folder>?rate=realtime|max&speed=1&loop=0|1&list=rgb.txt&gray=0|1
//   v4l2:/dev/video0?width=1280&height=720&fps=30&format=grey|yuyv|nv12|mjpeg&gray=0|1
//        &exposure=N&gain=N&buffers=4&timeout_ms=3000
//   libcamera:<camera id or index>?width=&height=&format=&gray=0|1&timeout_ms=3000
//   test:<pattern>?width=320&height=240&fps=30&frames=0&gray=0|1  (capture/test_pattern_source.h)
// A new source is one file: its class and a factory, registered with MM_REGISTER_FRAME_SOURCE
// in that file; mm_capture is linked whole (capture/CMakeLists.txt), so a registration the
// program never names is still there.

#include <charconv>
#include <map>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "capture/frame.h"
#include "capture/v4l2_source.h"

namespace mm {

/// Thrown for a URI that names no known source or has a bad parameter; the message names it.
class SourceUriError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// A camera URI taken apart (the query's keys sorted).
struct SourceUri {
  std::string text;    ///< The whole URI, for messages.
  std::string scheme;  ///< Before the first ':'.
  std::string target;  ///< Between ':' and '?' (folder, device, camera, pattern).
  std::map<std::string, std::string> params;
};

/// Splits a URI (throws SourceUriError when it has no scheme or a parameter has no value).
SourceUri ParseSourceUri(const std::string& uri);

/// `key=value` as a boolean (1/0, true/false, yes/no); throws SourceUriError naming it.
bool UriBool(const SourceUri& uri, const std::string& key, const std::string& value);

/// `key=value` as a number in [lo, hi]; throws SourceUriError naming it.
template <typename T>
T UriNumber(const SourceUri& uri, const std::string& key, const std::string& value, T lo, T hi) {
  T out{};
  const auto r = std::from_chars(value.data(), value.data() + value.size(), out);
  if (r.ec != std::errc() || r.ptr != value.data() + value.size() || out < lo || out > hi) {
    throw SourceUriError("camera URI '" + uri.text + "': " + key + "=" + value +
                         " (expected a number in " + std::to_string(lo) + ".." +
                         std::to_string(hi) + ")");
  }
  return out;
}

/// Makes (does not open) the source of a parsed URI; `base_dir` resolves relative paths.
/// Throws SourceUriError for a bad parameter.
using FrameSourceFactory = std::unique_ptr<FrameSource> (*)(const SourceUri& uri,
                                                            const std::string& base_dir);

/// Registers `scheme`. Returns true; a scheme registered twice throws std::logic_error.
[[nodiscard]] bool RegisterFrameSource(const std::string& scheme, FrameSourceFactory factory);

/// The registered schemes, sorted.
std::vector<std::string> FrameSourceSchemes();

/// In a source's .cc: MM_REGISTER_FRAME_SOURCE(replay, MakeReplaySource) registers
/// "replay" before main().
#define MM_REGISTER_FRAME_SOURCE(scheme, factory)                  \
  [[maybe_unused]] static const bool mm_frame_source_##scheme##_ = \
      ::mm::RegisterFrameSource(#scheme, factory)

/// The options of a v4l2: URI (throws SourceUriError naming the bad part).
V4l2Options ParseV4l2Uri(const std::string& uri);

/// Creates (does not open) the source a URI names through its scheme's factory. Relative
/// replay folders are resolved against `base_dir` (the config file's folder).
std::unique_ptr<FrameSource> CreateFrameSource(const std::string& uri,
                                               const std::string& base_dir = ".");

}  // namespace mm
