#pragma once
// Trigger sources behind one interface: each exposes an fd to poll (the daemon's epoll loop)
// and turns readiness into press events. GpioButton (libgpiod 1.6), SignalTrigger (SIGUSR1 via
// signalfd). The daemon's control socket is its own request/reply protocol and stays in
// firmware-app/app/control.*.
//
// Thread-safety: thread-bound.

#include <cstdint>
#include <memory>
#include <string>

#include "base/unique_fd.h"

namespace mm {

struct TriggerEvent {
  int64_t time_ns = 0;   ///< CLOCK_MONOTONIC of the event (the kernel's edge time for GPIO).
  bool pressed = true;   ///< true: press (the trigger); false: release (GPIO only).
  std::string source;    ///< e.g. "gpio gpiochip0:17", "SIGUSR1".
};

class Trigger {
 public:
  virtual ~Trigger() = default;
  /// Acquires the resource. Returns "" or a message naming what failed and why.
  [[nodiscard]] virtual std::string Open() = 0;
  /// The fd to poll for POLLIN (valid after a successful Open()).
  [[nodiscard]] virtual int fd() const = 0;
  /// After POLLIN: reads what is pending. Returns 1 with `event` filled, 0 when the pending
  /// input produced no event (e.g. a bounce), -1 on error (`error` filled).
  [[nodiscard]] virtual int ReadEvent(TriggerEvent* event, std::string* error) = 0;
  [[nodiscard]] virtual std::string Describe() const = 0;
};

/// Software debounce: an edge is ignored unless the line was quiet (no edge at all) for
/// `debounce_ns` before it, so a burst of contact bounce gives one press.
class Debouncer {
 public:
  explicit Debouncer(int64_t debounce_ns) : debounce_ns_(debounce_ns) {}
  /// Feeds one edge (`active`: the new logical level). Returns true when it is a press or
  /// release to report: the level changed from the last reported one after a quiet time.
  bool Edge(int64_t time_ns, bool active);
  [[nodiscard]] bool level() const { return level_; }

 private:
  int64_t debounce_ns_;
  int64_t last_edge_ns_ = INT64_MIN / 2;
  bool level_ = false;  // Last reported logical level.
};

struct GpioButtonOptions {
  std::string chip = "gpiochip0";  ///< Name, number, path or label (gpiod_chip_open_lookup).
  std::string line = "0";          ///< Offset or line name.
  bool active_low = true;          ///< Pressed pulls the line low (button to ground, pull-up).
  std::string bias = "as-is";      ///< as-is | pull-up | pull-down | disable.
  int debounce_ms = 30;            ///< Quiet time required before an edge counts (0: none).
  bool report_release = false;     ///< Also report releases.
  std::string consumer = "monomesh";

  [[nodiscard]] std::string Check() const;
};

class GpioButton final : public Trigger {
 public:
  explicit GpioButton(GpioButtonOptions options);
  ~GpioButton() override;
  GpioButton(const GpioButton&) = delete;
  GpioButton& operator=(const GpioButton&) = delete;

  [[nodiscard]] std::string Open() override;
  [[nodiscard]] int fd() const override { return fd_; }
  [[nodiscard]] int ReadEvent(TriggerEvent* event, std::string* error) override;
  [[nodiscard]] std::string Describe() const override;
  void Close();

  /// Edges seen and edges dropped by debounce, since Open().
  [[nodiscard]] uint64_t edges() const { return edges_; }
  [[nodiscard]] uint64_t bounces() const { return bounces_; }

 private:
  GpioButtonOptions options_;
  void* chip_ = nullptr;  // gpiod_chip*, owned.
  void* line_ = nullptr;  // gpiod_line*, requested (released in Close()).
  int fd_ = -1;           // Owned by libgpiod's line request.
  std::string name_;
  Debouncer debouncer_{0};
  uint64_t edges_ = 0, bounces_ = 0;
};

/// SIGUSR1 (or another signal) as a trigger: blocks it in the calling thread and reads it
/// through a signalfd. Call Open() before other threads start so they inherit the mask.
class SignalTrigger final : public Trigger {
 public:
  explicit SignalTrigger(int signal_number);
  [[nodiscard]] std::string Open() override;
  [[nodiscard]] int fd() const override { return fd_.get(); }
  [[nodiscard]] int ReadEvent(TriggerEvent* event, std::string* error) override;
  [[nodiscard]] std::string Describe() const override;

 private:
  int signal_;
  UniqueFd fd_;
};

}  // namespace mm
