#include "map/background_bundle.h"

#include <chrono>
#include <stdexcept>
#include <utility>

#include "base/clock.h"

namespace mm {
void BackgroundBundle::Start(const LocalBundleOptions& options, LocalBundleProblem problem) {
  if (running()) future_.wait();
  future_ = std::async(std::launch::async, [options, problem = std::move(problem)]() mutable {
    BackgroundBundleResult result;
    const double cpu_start = ThreadCpuSeconds();
    result.summary = AdjustLocalBundle(options, &problem);
    result.problem = std::move(problem);
    result.cpu_s = ThreadCpuSeconds() - cpu_start;
    return result;
  });
}

bool BackgroundBundle::done() const {
  return running() && future_.wait_for(std::chrono::seconds(0)) == std::future_status::ready;
}

BackgroundBundleResult BackgroundBundle::Take() {
  if (!running()) throw std::logic_error("BackgroundBundle::Take: no adjustment was started");
  return future_.get();
}

}  // namespace mm
