#pragma once
// JSON text for output, one place for every serializer of the appliance (control-socket
// replies, status, report.json, the evaluations' JSON). Strings come from outside (a frame
// file name, a client's command echoed back in an error) and need not be UTF-8; nlohmann's
// dump() throws on such a string, which ended the daemon. Here each invalid byte becomes
// U+FFFD instead, so the text is always valid UTF-8 and serializing never throws for it.
//
// Thread-safety: reentrant.

#include <nlohmann/json_fwd.hpp>
#include <string>

namespace mm {

/// `value` as JSON text, invalid UTF-8 replaced; `indent` < 0: one line, else pretty-printed.
[[nodiscard]] std::string JsonText(const nlohmann::json& value, int indent = -1);

}  // namespace mm
