#pragma once
// poll(2) for one descriptor until a deadline.
//
// Thread-safety: a free function; reentrant.

#include <poll.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstdint>

namespace mm {

/// Waits until `fd` has one of `events` (POLLIN, POLLOUT) or `deadline` passes, retrying
/// after signals (EINTR). Returns the events that ended the wait (`revents`: those asked for,
/// POLLERR, POLLHUP, ...; never 0), 0 when the deadline passed, -1 on error (errno set).
inline int PollFor(int fd, short events, std::chrono::steady_clock::time_point deadline) {
  for (;;) {
    // Rounded up: a truncated timeout would return before the deadline.
    const auto left =
        std::chrono::ceil<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now())
            .count();
    pollfd p{fd, events, 0};
    const int r = ::poll(&p, 1, static_cast<int>(std::max<int64_t>(0, left)));
    if (r > 0) return p.revents;
    if (r == 0 || errno != EINTR) return r;
  }
}

/// PollFor(fd, POLLIN, deadline).
inline int PollReadable(int fd, std::chrono::steady_clock::time_point deadline) {
  return PollFor(fd, POLLIN, deadline);
}

}  // namespace mm
