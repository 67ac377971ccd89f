// libFuzzer target for the control socket's request framing (the fuzz preset;
// scripts/fuzz.sh). The input is a sequence of reads: a length byte, then that many bytes,
// again and again, then the client shuts down writing. Whatever the split, the reader holds at
// most the limit plus one byte and ends with the same request and status as one read of all.

#include <algorithm>
#include <cstdint>
#include <cstdlib>
#include <string>
#include <string_view>

#include "app/control_protocol.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const auto* bytes = reinterpret_cast<const char*>(data);
  constexpr size_t kLimit = 32;  // Small, so the fuzzer reaches it.
  mm::ControlRequestReader pieces(kLimit);
  std::string whole;
  size_t at = 0;
  while (at < size) {
    const size_t n = std::min<size_t>(static_cast<uint8_t>(bytes[at]), size - at - 1);
    const std::string_view read(bytes + at + 1, n);
    whole.append(read);
    pieces.Append(read);
    if (pieces.request().size() > kLimit + 1) std::abort();
    at += 1 + n;
  }
  pieces.Finish();
  mm::ControlRequestReader one(kLimit);
  one.Append(whole);
  one.Finish();
  if (pieces.status() != one.status() || pieces.request() != one.request()) std::abort();
  if (one.status() == mm::ControlRequestReader::Status::kNeedMore) std::abort();
  return 0;
}
