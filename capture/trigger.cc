#include "capture/trigger.h"

#include <gpiod.h>
#include <signal.h>
#include <sys/signalfd.h>

#include <cerrno>
#include <charconv>
#include <cstring>

#include "capture/frame.h"

namespace mm {

bool Debouncer::Edge(int64_t time_ns, bool active) {
  const bool quiet = time_ns - last_edge_ns_ >= debounce_ns_;
  last_edge_ns_ = time_ns;
  if (!quiet || active == level_) return false;
  level_ = active;
  return true;
}

std::string GpioButtonOptions::Check() const {
  if (chip.empty()) return "gpio: no chip given";
  if (line.empty()) return "gpio: no line given";
  if (debounce_ms < 0 || debounce_ms > 10000) return "gpio: debounce_ms must be in 0..10000";
  if (bias != "as-is" && bias != "pull-up" && bias != "pull-down" && bias != "disable") {
    return "gpio: bias '" + bias + "' (expected as-is, pull-up, pull-down or disable)";
  }
  return {};
}

GpioButton::GpioButton(GpioButtonOptions options) : options_(std::move(options)) {
  name_ = "gpio " + options_.chip + ":" + options_.line;
}

GpioButton::~GpioButton() { Close(); }

void GpioButton::Close() {
  if (line_) gpiod_line_release(static_cast<gpiod_line*>(line_));
  line_ = nullptr;
  fd_ = -1;
  if (chip_) gpiod_chip_close(static_cast<gpiod_chip*>(chip_));
  chip_ = nullptr;
}

std::string GpioButton::Open() {
  if (std::string e = options_.Check(); !e.empty()) return e;
  Close();
  gpiod_chip* chip = gpiod_chip_open_lookup(options_.chip.c_str());
  if (!chip) {
    const int err = errno;
    std::string why = err == ENOENT || err == ENODEV ? "no such chip (see `gpiodetect`)"
                      : err == EACCES               ? "permission denied (add the user to group 'gpio')"
                                                    : std::strerror(err);
    return "gpio: chip '" + options_.chip + "': " + why;
  }
  chip_ = chip;
  const std::string chip_name = gpiod_chip_name(chip);
  const unsigned num_lines = gpiod_chip_num_lines(chip);
  unsigned offset = 0;
  gpiod_line* line = nullptr;
  const auto r = std::from_chars(options_.line.data(), options_.line.data() + options_.line.size(), offset);
  if (r.ec == std::errc() && r.ptr == options_.line.data() + options_.line.size()) {
    if (offset >= num_lines) {
      const std::string e = "gpio: " + chip_name + " ('" + gpiod_chip_label(chip) + "') has lines 0.." +
                            std::to_string(num_lines - 1) + ", not " + options_.line;
      Close();
      return e;
    }
    line = gpiod_chip_get_line(chip, offset);
  } else {
    line = gpiod_chip_find_line(chip, options_.line.c_str());
    if (!line) {
      const std::string e = "gpio: " + chip_name + " has no line named '" + options_.line + "'";
      Close();
      return e;
    }
  }
  if (!line) {
    const std::string e = "gpio: " + chip_name + " line " + options_.line + ": " + std::strerror(errno);
    Close();
    return e;
  }
  int flags = options_.active_low ? GPIOD_LINE_REQUEST_FLAG_ACTIVE_LOW : 0;
  if (options_.bias == "pull-up") flags |= GPIOD_LINE_REQUEST_FLAG_BIAS_PULL_UP;
  if (options_.bias == "pull-down") flags |= GPIOD_LINE_REQUEST_FLAG_BIAS_PULL_DOWN;
  if (options_.bias == "disable") flags |= GPIOD_LINE_REQUEST_FLAG_BIAS_DISABLE;
  if (gpiod_line_request_both_edges_events_flags(line, options_.consumer.c_str(), flags) != 0) {
    const int err = errno;
    std::string why;
    if (err == EBUSY) {
      gpiod_line_update(line);
      const char* consumer = gpiod_line_consumer(line);
      why = std::string("line is in use by '") + (consumer ? consumer : "another process") + "'";
    } else if (err == EPERM || err == EACCES) {
      why = "permission denied (add the user to group 'gpio')";
    } else if (err == EINVAL || err == EOPNOTSUPP) {
      why = std::string("the chip refused the request (") + std::strerror(err) +
            "): bias or edge events not supported on this line?";
    } else {
      why = std::strerror(err);
    }
    Close();
    return "gpio: " + chip_name + " line " + options_.line + ": cannot request edge events: " + why;
  }
  line_ = line;
  fd_ = gpiod_line_event_get_fd(line);
  name_ = "gpio " + chip_name + ":" + std::to_string(gpiod_line_offset(line));
  debouncer_ = Debouncer(static_cast<int64_t>(options_.debounce_ms) * 1000000);
  // Start from the line's current level, so the first edge is judged against it.
  const int value = gpiod_line_get_value(line);
  if (value > 0) debouncer_.Edge(INT64_MIN / 4, true);
  edges_ = bounces_ = 0;
  return {};
}

int GpioButton::ReadEvent(TriggerEvent* event, std::string* error) {
  if (!line_) {
    if (error) *error = name_ + ": not open";
    return -1;
  }
  gpiod_line_event ev{};
  if (gpiod_line_event_read_fd(fd_, &ev) != 0) {
    if (errno == EAGAIN) return 0;
    if (error) *error = name_ + ": reading the event: " + std::strerror(errno);
    return -1;
  }
  ++edges_;
  const int64_t t = static_cast<int64_t>(ev.ts.tv_sec) * 1000000000LL + ev.ts.tv_nsec;
  const bool active = ev.event_type == GPIOD_LINE_EVENT_RISING_EDGE;  // Logical (active-low applied).
  if (!debouncer_.Edge(t, active)) {
    ++bounces_;
    return 0;
  }
  if (!active && !options_.report_release) return 0;
  event->time_ns = t;
  event->pressed = active;
  event->source = name_;
  return 1;
}

std::string GpioButton::Describe() const {
  return name_ + (options_.active_low ? " active-low" : " active-high") + ", debounce " +
         std::to_string(options_.debounce_ms) + " ms, bias " + options_.bias;
}

SignalTrigger::SignalTrigger(int signal_number) : signal_(signal_number) {}

std::string SignalTrigger::Open() {
  sigset_t mask;
  sigemptyset(&mask);
  sigaddset(&mask, signal_);
  if (pthread_sigmask(SIG_BLOCK, &mask, nullptr) != 0) return "signal trigger: cannot block the signal";
  fd_.reset(signalfd(-1, &mask, SFD_NONBLOCK | SFD_CLOEXEC));
  if (!fd_.valid()) return std::string("signal trigger: signalfd: ") + std::strerror(errno);
  return {};
}

int SignalTrigger::ReadEvent(TriggerEvent* event, std::string* error) {
  signalfd_siginfo info{};
  const ssize_t n = ::read(fd_.get(), &info, sizeof info);
  if (n != static_cast<ssize_t>(sizeof info)) {
    if (n < 0 && errno == EAGAIN) return 0;
    if (error) *error = std::string("signal trigger: read: ") + std::strerror(errno);
    return -1;
  }
  event->time_ns = MonotonicNowNs();
  event->pressed = true;
  event->source = strsignal(static_cast<int>(info.ssi_signo));
  if (static_cast<int>(info.ssi_signo) == SIGUSR1) event->source = "SIGUSR1";
  return 1;
}

std::string SignalTrigger::Describe() const { return std::string("signal ") + strsignal(signal_); }

}  // namespace mm
