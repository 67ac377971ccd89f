#pragma once
// The daemon's configuration: one TOML file (systemd/monomeshd.example.toml documents every
// key). Unknown keys and bad values are errors that name the key; the daemon exits with
// EX_CONFIG (78) on them.

#include <filesystem>
#include <stdexcept>
#include <string>
#include <vector>

#include "app/hooks.h"
#include "capture/trigger.h"
#include "map/walk_map.h"
#include "map/walk_mesh.h"
#include "recon/keyframe_gate.h"
#include "recon/pipeline.h"
#include "scale/metric_scale.h"
#include "session/capture_session.h"

namespace mm {

class ConfigError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct DaemonConfig {
  std::filesystem::path config_dir;  ///< Relative paths below are resolved against this.

  std::string camera_uri;             ///< [camera] uri
  std::filesystem::path calibration;  ///< [camera] calibration

  std::filesystem::path control_socket = "/run/monomesh/control.sock";  ///< [control] socket
  /// [control] group: the socket's group, so its members run `monomesh ctl` without sudo; empty
  /// leaves the daemon's own group. Resolved when the daemon binds the socket.
  std::string control_group = "monomesh";
  /// Whether the file names [control] group. A named group that does not exist stops the daemon
  /// (the package's config names it); the default's absence (a build tree, no package) is a
  /// warning and the socket keeps the daemon's group.
  bool control_group_given = false;
  int control_mode = 0660;  ///< [control] mode: the socket's permission bits (0 to 0777).

  /// [trigger] gpio_chip, gpio_line, active_low, bias, debounce_ms: the capture button.
  /// Empty chip: no button (the control socket and SIGUSR1 still trigger).
  GpioButtonOptions button;
  bool button_enabled = false;
  /// [trigger] long_press_ms: a press held this long starts or stops a walk, a shorter one is
  /// a capture (acted on at the release). 0: every press is a capture, at the press.
  int long_press_ms = 1000;

  KeyframeGateOptions gate;          ///< [keyframes] parallax_deg, min_tracks, min_inliers
  double keyframe_timeout_s = 30.0;  ///< [keyframes] timeout_s
  int max_b_tries = CaptureSessionOptions{}.max_tries;  ///< [keyframes] max_tries

  PairOptions recon;  ///< [recon] ...

  /// [walk]: walk mode (docs/walk.md), `monomesh ctl walk start|stop` or a long press.
  struct Walk {
    /// The walk's gate: [keyframes] and [recon] tests with [walk] parallax_deg.
    KeyframeGateOptions gate;
    WalkOptions map;
    int max_keyframes = 300;   ///< [walk] max_keyframes: the walk ends ("keyframe limit").
    double timeout_s = 900.0;  ///< [walk] timeout_s: the walk ends ("timeout").
    bool dense_mesh = true;    ///< [walk] mesh: dense (default) or sparse keyframe meshes.
    int max_mesh_parts = WalkMeshOptions{}.max_parts;  ///< [walk] max_mesh_parts
    /// [walk] refine: the map refined once the walk ends, before its mesh (map/walk_refine.h).
    bool refine = true;
  };
  Walk walk;

  /// [scale] source, camera_height_m, camera_pitch_deg, min_baseline_m: metres for the
  /// entries (scale/metric_scale.h); source none leaves them up to scale.
  ScaleOptions scale;
  /// [scale] max_odom_age_s: odometry further than this from a keyframe's time is stale; the
  /// worker also waits up to this long for the odometry stream to reach keyframe B's time.
  double max_odom_age_s = 0.5;
  /// [scale] odometry_clock: the clock of `odom` timestamps. Realtime: Unix time (a ROS
  /// bridge's stamps); camera: the frames' own timestamps (the replay camera's dataset time,
  /// a V4L2 driver's CLOCK_MONOTONIC).
  enum class OdometryClock { kRealtime, kCamera };
  OdometryClock odometry_clock = OdometryClock::kRealtime;

  /// [spool] dir. The default is in the unit's StateDirectory (/var/lib/monomesh), the one
  /// place besides /run/monomesh the unit lets the daemon write.
  std::filesystem::path spool_dir = "/var/lib/monomesh/spool";
  int spool_max_entries = 200;  ///< [spool] max_entries (0 = keep all)

  /// [hooks] on_entry, on_failure (commands: a program's path and its arguments, split at
  /// spaces, no shell), timeout_s.
  HookOptions hooks;

  /// [web]: monomesh-web, the operator's page (docs/web.md); the daemon only checks these.
  struct Web {
    std::string listen_host = "127.0.0.1";  ///< [web] listen "HOST:PORT"
    int listen_port = 8080;
    /// [web] token_file: the bearer token every POST must carry.
    std::filesystem::path token_file = "/etc/monomesh/web-token";
    std::filesystem::path static_dir = "/usr/share/monomesh/web";     ///< [web] static_dir
    std::filesystem::path three_dir = "/usr/share/javascript/three";  ///< [web] three_dir
  };
  Web web;

  std::string log_level = "info";  ///< [log] level: trace|debug|info|warn|error
};

/// Every key the parser knows, as "table.key", in the order of the example config.
const std::vector<std::string>& DaemonConfigKeys();

/// Reads and validates a config file.
/// \throws ConfigError naming the file, line and key.
DaemonConfig LoadDaemonConfig(const std::filesystem::path& path);
DaemonConfig ParseDaemonConfig(const std::string& text, const std::filesystem::path& path);

}  // namespace mm
