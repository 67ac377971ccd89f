#pragma once
// The control protocol without the socket (control.h): request lines, which may arrive in
// pieces and end at '\n' (or where the client shuts down writing), each answered by one JSON
// line. A connection carries one command, except that `odom` lines (a robot's odometry bridge)
// may follow each other on one connection, and that `watch` turns the connection into a
// subscription: the daemon writes one JSON line per event until either side closes. Pure, so the
// framing and the command parser are unit-tested and fuzzed apart from the daemon.

#include <cstddef>
#include <string>
#include <string_view>

namespace mm {

/// The longest request line the daemon reads (the longest, an `odom` line with a quaternion
/// in full precision, is about 200 bytes).
inline constexpr size_t kMaxControlRequestBytes = 256;

/// Collects request lines from a client's reads.
class ControlRequestReader {
 public:
  enum class Status {
    kNeedMore,  ///< No complete line yet: read again.
    kComplete,  ///< request() is a line, without its '\n'.
    kTooLong,   ///< A line longer than max_bytes: answer an error and close.
    kEmpty,     ///< The client shut down writing with nothing pending: close silently.
  };

  explicit ControlRequestReader(size_t max_bytes = kMaxControlRequestBytes)
      : max_bytes_(max_bytes) {}

  /// Adds the bytes of one read. While the status is kComplete (a line not yet taken by Next)
  /// or kTooLong, bytes are kept (kComplete) or ignored (kTooLong).
  Status Append(std::string_view bytes);
  /// The client shut down writing (recv returned 0): a pending partial line is complete.
  Status Finish();
  /// Drops the current line and looks at what came after it.
  Status Next();

  [[nodiscard]] Status status() const { return status_; }
  [[nodiscard]] const std::string& request() const { return request_; }
  /// Bytes held beyond the current line (at most one read's worth plus max_bytes).
  [[nodiscard]] size_t buffered() const { return pending_.size(); }

 private:
  Status Scan();

  size_t max_bytes_;
  std::string pending_;  // Bytes after the current line.
  std::string request_;
  bool finished_ = false;
  Status status_ = Status::kNeedMore;
};

enum class ControlCommand {
  kTrigger,
  kStatus,
  kPing,
  kOdom,
  kWatch,
  kWalkStart,
  kWalkStop,
  kUnknown
};

/// The command a request line names (its first word, for `odom` the rest are its arguments);
/// a trailing '\r' (a telnet line) is ignored.
ControlCommand ParseControlCommand(std::string_view line);

/// The arguments of an `odom` line ("odom T X Y Z ..." -> "T X Y Z ...").
std::string_view OdomArguments(std::string_view line);

/// The error that answers an unknown command; it quotes the request, which need not be UTF-8
/// (the reply's JSON text replaces what is not, entry/json_text.h).
std::string UnknownControlCommandError(std::string_view request);

}  // namespace mm
