// libFuzzer target for one control-socket request line: the command parser and the reply that
// quotes it (the fuzz preset; scripts/fuzz.sh). Any bytes give a command, and the reply's JSON
// text is valid JSON that reads back (a non-UTF-8 byte once ended the daemon).

#include <cstdint>
#include <cstdlib>
#include <nlohmann/json.hpp>
#include <string>

#include "app/control_protocol.h"
#include "entry/json_text.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string line(reinterpret_cast<const char*>(data), size);
  if (mm::ParseControlCommand(line) != mm::ControlCommand::kUnknown) return 0;
  const nlohmann::json reply = {{"ok", false}, {"error", mm::UnknownControlCommandError(line)}};
  const std::string text = mm::JsonText(reply);
  const nlohmann::json back = nlohmann::json::parse(text, nullptr, /*allow_exceptions=*/false);
  if (back.is_discarded() || !back.is_object() || back.value("ok", true)) std::abort();
  return 0;
}
