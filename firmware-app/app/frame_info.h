#pragma once
// A captured frame as a keyframe of a report (entry/report.h): its sequence, times and source.

#include "base/wall_clock.h"
#include "capture/frame.h"
#include "entry/report.h"

namespace mm {

inline KeyframeInfo KeyframeInfoOf(const Frame& f) {
  return {.sequence = f.sequence,
          .source_time_s = f.source_time_s,
          .capture_time_ns = f.capture_time_ns,
          .capture_realtime_ns = RealtimeFromMonotonicNs(f.capture_time_ns),
          .source = f.source_id};
}

}  // namespace mm
