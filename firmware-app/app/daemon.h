#pragma once
// monomeshd: the appliance daemon.
//
// Threads (docs/architecture.md):
//   event loop (Run's caller): epoll over signalfd (SIGTERM/SIGINT stop, SIGUSR1 trigger),
//     a timerfd (timeouts, watchdog), the control socket and its clients, and two eventfds
//     (new frame from the capture thread, job done from the worker). All state lives here.
//   capture thread (CaptureThread): camera -> newest-frame slot, never blocks.
//   worker thread: one job at a time (bounded queue of one): undistort both keyframes,
//     reconstruct, encode, commit the spool entry.
//
// States: idle -> (trigger: keyframe A = newest frame) tracking -> (keyframe B taken)
// reconstructing -> idle. A trigger outside idle is refused with the state named.
//
// The loop is the Daemon class (app/daemon_loop.h), its methods defined by concern in
// app/daemon.cc, capture_state.cc, walk_control.cc, control_clients.cc, control_verbs.cc,
// events.cc and shutdown.cc; the worker is app/worker.h (docs/architecture.md, the daemon's
// files).

#include <memory>
#include <string>

#include "app/config.h"

namespace mm {

/// Runs the daemon until SIGTERM/SIGINT. Returns the process exit code (0 on a clean stop).
int RunDaemon(const DaemonConfig& config);

}  // namespace mm
