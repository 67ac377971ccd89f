#pragma once
// The loss/reopen bookkeeping shared by the device sources (V4l2Source, LibcameraSource):
// a device is lost when it reports an error or stays silent for `lost_after_ms`; reopen
// attempts are then spaced by exponential back-off (reopen_min_ms, doubling up to
// reopen_max_ms) and capture resumes after the first successful attempt.
//
// Thread-safety: the counters are atomic (read from any thread); the rest belongs to the
// thread calling the source's Read().

#include <atomic>
#include <chrono>
#include <cstdint>

namespace mm {

struct RecoveryOptions {
  int lost_after_ms = 3000;  ///< No frame for this long while streaming: the device is lost.
  int reopen_min_ms = 100;   ///< First reopen attempt after a loss; doubles after each failure.
  int reopen_max_ms = 2000;  ///< Back-off ceiling.
};

class DeviceRecovery {
 public:
  using Clock = std::chrono::steady_clock;

  explicit DeviceRecovery(RecoveryOptions options = {}) : options_(options) {}

  /// After a successful Open(): not lost, the silence clock starts now.
  void Reset();
  /// A frame arrived (restarts the silence clock).
  void FrameArrived() { last_frame_ = Clock::now(); }
  /// True when nothing arrived for lost_after_ms.
  [[nodiscard]] bool Silent() const;
  /// Marks the device lost (the caller has closed it); the first reopen is due after reopen_min_ms.
  void Lose();
  [[nodiscard]] bool lost() const { return lost_; }

  /// While lost: true when a reopen attempt is due; otherwise sleeps until the attempt is due
  /// or `deadline`, whichever is first, and returns false.
  bool AttemptDue(Clock::time_point deadline);
  /// The reopen attempt failed: the next one is due after twice the last delay (capped).
  void AttemptFailed();
  /// The reopen attempt succeeded: capture resumes.
  void AttemptSucceeded();

  [[nodiscard]] uint64_t losses() const { return losses_; }
  [[nodiscard]] uint64_t reopens() const { return reopens_; }
  [[nodiscard]] int backoff_ms() const { return backoff_ms_; }

 private:
  RecoveryOptions options_;
  bool lost_ = false;
  int backoff_ms_ = 0;
  Clock::time_point next_attempt_;
  Clock::time_point last_frame_;
  std::atomic<uint64_t> losses_{0}, reopens_{0};
};

}  // namespace mm
