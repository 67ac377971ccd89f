#pragma once
// poll(2) for one readable descriptor until a deadline.
//
// Thread-safety: a free function; reentrant.

#include <poll.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstdint>

namespace mm {

/// Waits until `fd` is readable or `deadline` passes, retrying after signals (EINTR).
/// Returns the events that ended the wait (`revents`: POLLIN, POLLERR, POLLHUP, ...; never 0),
/// 0 when the deadline passed, -1 on error (errno set).
inline int PollReadable(int fd, std::chrono::steady_clock::time_point deadline) {
  for (;;) {
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(
                          deadline - std::chrono::steady_clock::now())
                          .count();
    pollfd p{fd, POLLIN, 0};
    const int r = ::poll(&p, 1, static_cast<int>(std::max<int64_t>(0, left)));
    if (r > 0) return p.revents;
    if (r == 0 || errno != EINTR) return r;
  }
}

}  // namespace mm
