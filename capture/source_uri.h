#pragma once
// Frame sources selected by URI:
//   replay:<folder>?rate=realtime|max&speed=1&loop=0|1&list=rgb.txt&gray=0|1
//   v4l2:/dev/video0?width=1280&height=720&fps=30&format=grey|yuyv|nv12|mjpeg&gray=0|1
//        &exposure=N&gain=N&buffers=4&timeout_ms=3000
//   libcamera:<camera id or index>?width=&height=&format=&gray=0|1&timeout_ms=3000

#include <memory>
#include <stdexcept>
#include <string>

#include "capture/frame.h"
#include "capture/v4l2_source.h"

namespace mm {

/// Thrown for a URI that names no known source or has a bad parameter; the message names it.
class SourceUriError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// The options of a v4l2: URI (throws SourceUriError naming the bad part).
V4l2Options ParseV4l2Uri(const std::string& uri);

/// Creates (does not open) the source a URI names. Relative replay folders are resolved
/// against `base_dir` (the config file's folder).
std::unique_ptr<FrameSource> CreateFrameSource(const std::string& uri,
                                               const std::string& base_dir = ".");

}  // namespace mm
