// libFuzzer target for the control socket's request framing (the fuzz preset;
// scripts/fuzz.sh). The input is a sequence of reads: a length byte, then that many bytes,
// again and again, then the client shuts down writing. Whatever the split, the lines taken
// are those of one read of everything, with the same final status, and the reader never
// holds more than one read plus the limit.

#include <algorithm>
#include <cstdint>
#include <cstdlib>
#include <string>
#include <string_view>
#include <vector>

#include "app/control_protocol.h"

namespace {

using Reader = mm::ControlRequestReader;

// Takes every complete line (as the daemon does after each read).
void TakeLines(Reader& reader, std::vector<std::string>* lines) {
  while (reader.status() == Reader::Status::kComplete) {
    lines->push_back(reader.request());
    reader.Next();
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const auto* bytes = reinterpret_cast<const char*>(data);
  constexpr size_t kLimit = 32;  // Small, so the fuzzer reaches it.
  Reader pieces(kLimit);
  std::vector<std::string> lines_in_pieces;
  std::string whole;
  size_t at = 0;
  while (at < size) {
    const size_t n = std::min<size_t>(static_cast<uint8_t>(bytes[at]), size - at - 1);
    const std::string_view read(bytes + at + 1, n);
    whole.append(read);
    pieces.Append(read);
    TakeLines(pieces, &lines_in_pieces);
    if (pieces.buffered() > kLimit + 256 || pieces.request().size() > kLimit) std::abort();
    at += 1 + n;
  }
  pieces.Finish();
  TakeLines(pieces, &lines_in_pieces);

  Reader one(kLimit);
  std::vector<std::string> lines_in_one;
  one.Append(whole);
  TakeLines(one, &lines_in_one);
  one.Finish();
  TakeLines(one, &lines_in_one);
  if (pieces.status() != one.status() || lines_in_pieces != lines_in_one) std::abort();
  if (one.status() != Reader::Status::kEmpty && one.status() != Reader::Status::kTooLong) {
    std::abort();
  }
  for (const std::string& line : lines_in_one) {
    if (line.size() > kLimit || line.find('\n') != std::string::npos) std::abort();
  }
  return 0;
}
