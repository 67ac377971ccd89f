#pragma once
// Frame sources selected by URI:
//   replay:<folder>?rate=realtime|max&speed=1&loop=0|1&list=rgb.txt&gray=0|1

#include <memory>
#include <stdexcept>
#include <string>

#include "capture/frame.h"

namespace mm {

/// Thrown for a URI that names no known source or has a bad parameter; the message names it.
class SourceUriError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// Creates (does not open) the source a URI names. Relative replay folders are resolved
/// against `base_dir` (the config file's folder).
std::unique_ptr<FrameSource> CreateFrameSource(const std::string& uri,
                                               const std::string& base_dir = ".");

}  // namespace mm
