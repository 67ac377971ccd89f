#pragma once
// The daemon's eventfds: a thread signals the event loop, the loop drains the count.

#include <unistd.h>

#include <cstdint>

namespace mm {

inline void SignalEventFd(int fd) {
  const uint64_t one = 1;
  [[maybe_unused]] const ssize_t n = ::write(fd, &one, sizeof(one));
}

inline void DrainEventFd(int fd) {
  uint64_t value = 0;
  [[maybe_unused]] const ssize_t n = ::read(fd, &value, sizeof(value));
}

}  // namespace mm
