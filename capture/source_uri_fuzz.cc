// libFuzzer target for camera URIs ([camera] uri: the URI splitter and every registered
// scheme's parameter parser; the fuzz preset, scripts/fuzz.sh). Any input makes a source
// (made, not opened) or throws SourceUriError; nothing else escapes.

#include <cstdint>
#include <cstdlib>
#include <string>

#include "capture/source_uri.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string uri(reinterpret_cast<const char*>(data), size);
  try {
    const std::unique_ptr<mm::FrameSource> source = mm::CreateFrameSource(uri, "/nonexistent");
    if (source == nullptr || source->Describe().empty()) std::abort();
  } catch (const mm::SourceUriError&) {
  }
  try {
    const mm::SourceUri parsed = mm::ParseSourceUri(uri);
    if (parsed.text != uri || parsed.scheme.empty()) std::abort();
  } catch (const mm::SourceUriError&) {
  }
  return 0;
}
