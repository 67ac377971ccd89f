#pragma once
// The control protocol without the socket (control.h): one request line per connection, which
// may arrive in pieces and ends at '\n' or when the client shuts down writing; then one command.
// Pure, so the framing and the command parser are unit-tested and fuzzed apart from the daemon.

#include <cstddef>
#include <string>
#include <string_view>

namespace mm {

/// The longest request line the daemon reads (the longest command is 7 bytes).
inline constexpr size_t kMaxControlRequestBytes = 256;

/// Collects one request line from a client's reads.
class ControlRequestReader {
 public:
  enum class Status {
    kNeedMore,  ///< No end of line yet: read again.
    kComplete,  ///< request() is the line, without its '\n'.
    kTooLong,   ///< More than max_bytes without an end of line: answer an error and close.
    kEmpty,     ///< The client shut down writing without sending anything: close silently.
  };

  explicit ControlRequestReader(size_t max_bytes = kMaxControlRequestBytes)
      : max_bytes_(max_bytes) {}

  /// Adds the bytes of one read. Once the status is not kNeedMore it stays as it is.
  Status Append(std::string_view bytes);
  /// The client shut down writing (recv returned 0): what came is the whole request.
  Status Finish();

  Status status() const { return status_; }
  const std::string& request() const { return request_; }
  std::string TakeRequest() { return std::move(request_); }

 private:
  size_t max_bytes_;
  std::string request_;
  Status status_ = Status::kNeedMore;
};

enum class ControlCommand { kTrigger, kStatus, kPing, kUnknown };

/// The command a request line names; a trailing '\r' (a telnet line) is ignored.
ControlCommand ParseControlCommand(std::string_view line);

/// The error that answers an unknown command; it quotes the request, which need not be UTF-8
/// (the reply's JSON text replaces what is not, entry/json_text.h).
std::string UnknownControlCommandError(std::string_view request);

}  // namespace mm
