#include "app/config.h"

#include <arpa/inet.h>
#include <sys/un.h>
#include <toml++/toml.h>
#include <unistd.h>

#include <charconv>
#include <set>
#include <type_traits>

#include "base/checked_number.h"
#include "base/text_file.h"

namespace mm {
namespace {

// Walks the tables, checks for unknown keys and converts values, naming the key on errors.
class Reader {
 public:
  Reader(const toml::table& root, std::string source) : root_(root), source_(std::move(source)) {}

  [[noreturn]] void Fail(const toml::node* node, const std::string& key, const std::string& what) {
    std::string msg = source_;
    if (node != nullptr && node->source().begin.line > 0) {
      msg += ":" + std::to_string(node->source().begin.line);
    }
    throw ConfigError(msg + ": key '" + key + "': " + what);
  }

  const toml::table* Table(const std::string& name) {
    known_tables_.insert(name);
    std::set<std::string> allowed;
    for (const std::string& k : DaemonConfigKeys()) {
      if (k.starts_with(name + ".")) allowed.insert(k.substr(name.size() + 1));
    }
    const toml::node* node = root_.get(name);
    if (node == nullptr) return nullptr;
    const toml::table* table = node->as_table();
    if (table == nullptr) Fail(node, name, "expected a table [" + name + "]");
    for (const auto& [key, value] : *table) {
      if (!allowed.contains(std::string(key.str()))) {
        std::string list;
        for (const auto& a : allowed) list += (list.empty() ? "" : ", ") + a;
        Fail(&value, name + "." + std::string(key.str()), "unknown key (known: " + list + ")");
      }
    }
    return table;
  }

  void CheckTopLevel() {
    for (const auto& [key, value] : root_) {
      if (!known_tables_.contains(std::string(key.str()))) {
        Fail(&value, std::string(key.str()), "unknown table");
      }
    }
  }

  // Strings and booleans. A boolean must be written true / false (toml++'s value<bool> also
  // takes integers). Numbers go through GetNumber.
  template <typename T>
  void Get(const toml::table* table, const std::string& tname, const char* key, T* out) {
    static_assert(std::is_same_v<T, bool> || std::is_same_v<T, std::string>);
    if (table == nullptr) return;
    const toml::node* node = table->get(key);
    if (node == nullptr) return;
    const std::optional<T> v = node->value_exact<T>();
    if (!v) Fail(node, tname + "." + key, "wrong type");
    *out = *v;
  }

  // Every number: of the field's type within its range (base/checked_number.h).
  template <typename T>
  void GetNumber(const toml::table* table, const std::string& tname, const char* key,
                 NumberRange<T> range, T* out) {
    if (table == nullptr) return;
    const toml::node* node = table->get(key);
    if (node == nullptr) return;
    std::string problem;
    const std::optional<T> v = CheckedNumberOf<T>(*node, range, &problem);
    if (!v) Fail(node, tname + "." + key, problem);
    *out = *v;
  }

  // A word naming one of T's values: `parse` maps a word to a value (nullopt for another
  // word), `name` a value to its word (for the default). `what` ends "'word' is not ...".
  template <typename T, typename Parse, typename Name>
  void GetChoice(const toml::table* table, const std::string& tname, const char* key, Parse parse,
                 Name name, const std::string& what, T* out) {
    std::string word = name(*out);
    Get(table, tname, key, &word);
    const std::optional<T> value = parse(word);
    Require(value.has_value(), table, tname, key, "'" + word + "' is not " + what);
    *out = *value;
  }

  void GetPath(const toml::table* table, const std::string& tname, const char* key,
               const std::filesystem::path& base, std::filesystem::path* out) {
    std::string s;
    Get(table, tname, key, &s);
    if (s.empty()) return;
    const std::filesystem::path p(s);
    *out = p.is_absolute() ? p : (base / p).lexically_normal();
  }

  void Require(bool ok, const toml::table* table, const std::string& tname, const char* key,
               const std::string& what) {
    if (ok) return;
    const toml::node* node = table ? table->get(key) : nullptr;
    Fail(node, tname + "." + key, what);
  }

 private:
  const toml::table& root_;
  std::string source_;
  std::set<std::string> known_tables_;
};

// The upper bound of the count keys (features, tracks, inliers, entries): far above any use,
// far below INT_MAX.
constexpr int kMaxCount = 1'000'000;

// "HOST:PORT" with HOST a dotted IPv4 address (no name lookup: the service binds before the
// network may be up) and PORT 1 to 65535.
bool ParseListenAddress(const std::string& text, std::string* host, int* port) {
  const size_t colon = text.rfind(':');
  if (colon == std::string::npos) return false;
  const std::string h = text.substr(0, colon);
  in_addr addr{};
  if (::inet_pton(AF_INET, h.c_str(), &addr) != 1) return false;
  int p = 0;
  const char* begin = text.data() + colon + 1;
  const char* end = text.data() + text.size();
  const auto [stop, ec] = std::from_chars(begin, end, p);
  if (begin == end || ec != std::errc() || stop != end || p < 1 || p > 65535) return false;
  *host = h;
  *port = p;
  return true;
}

}  // namespace

const std::vector<std::string>& DaemonConfigKeys() {
  static const std::vector<std::string> kKeys{"camera.uri",
                                              "camera.calibration",
                                              "control.socket",
                                              "control.group",
                                              "control.mode",
                                              "trigger.gpio_chip",
                                              "trigger.gpio_line",
                                              "trigger.active_low",
                                              "trigger.bias",
                                              "trigger.debounce_ms",
                                              "trigger.long_press_ms",
                                              "keyframes.parallax_deg",
                                              "keyframes.min_tracks",
                                              "keyframes.min_inliers",
                                              "keyframes.max_tries",
                                              "keyframes.timeout_s",
                                              "recon.min_parallax_deg",
                                              "recon.sift",
                                              "recon.max_features",
                                              "recon.contrast_threshold",
                                              "recon.match_ratio",
                                              "recon.ransac_threshold_px",
                                              "recon.min_inliers",
                                              "recon.max_depth_ratio",
                                              "recon.refine_points",
                                              "mesh.mode",
                                              "mesh.vertex_budget",
                                              "walk.parallax_deg",
                                              "walk.max_keyframes",
                                              "walk.timeout_s",
                                              "walk.mesh",
                                              "walk.max_mesh_parts",
                                              "walk.refine",
                                              "scale.source",
                                              "scale.camera_height_m",
                                              "scale.camera_pitch_deg",
                                              "scale.min_baseline_m",
                                              "scale.max_odom_age_s",
                                              "scale.odometry_clock",
                                              "spool.dir",
                                              "spool.max_entries",
                                              "hooks.on_entry",
                                              "hooks.on_failure",
                                              "hooks.timeout_s",
                                              "web.listen",
                                              "web.token_file",
                                              "web.static_dir",
                                              "web.three_dir",
                                              "log.level"};
  return kKeys;
}

DaemonConfig ParseDaemonConfig(const std::string& text, const std::filesystem::path& path) {
  toml::table root;
  try {
    root = toml::parse(text, path.string());
  } catch (const toml::parse_error& e) {
    throw ConfigError(path.string() + ":" + std::to_string(e.source().begin.line) +
                      ": not valid TOML: " + std::string(e.description()));
  }
  DaemonConfig c;
  c.config_dir = path.parent_path().empty() ? std::filesystem::path(".") : path.parent_path();
  Reader r(root, path.string());

  const auto* camera = r.Table("camera");
  r.Get(camera, "camera", "uri", &c.camera_uri);
  r.GetPath(camera, "camera", "calibration", c.config_dir, &c.calibration);
  r.Require(!c.camera_uri.empty(), camera, "camera", "uri", "missing (e.g. \"replay:DIR\")");
  r.Require(!c.calibration.empty(), camera, "camera", "calibration", "missing");

  const auto* control = r.Table("control");
  r.GetPath(control, "control", "socket", c.config_dir, &c.control_socket);
  r.Require(c.control_socket.string().size() < sizeof(sockaddr_un{}.sun_path), control, "control",
            "socket",
            "longer than " + std::to_string(sizeof(sockaddr_un{}.sun_path) - 1) +
                " bytes (the limit of a UNIX socket address)");
  r.Get(control, "control", "group", &c.control_group);
  c.control_group_given = control != nullptr && control->contains("group");
  r.GetNumber(control, "control", "mode", {0, 0777}, &c.control_mode);

  const auto* trigger = r.Table("trigger");
  std::string chip;
  r.Get(trigger, "trigger", "gpio_chip", &chip);
  r.GetNumber(trigger, "trigger", "long_press_ms", {0, 60000}, &c.long_press_ms);
  c.button.report_release = c.long_press_ms > 0;
  if (!chip.empty()) {
    c.button_enabled = true;
    c.button.chip = chip;
    r.Get(trigger, "trigger", "gpio_line", &c.button.line);
    r.Require(!c.button.line.empty(), trigger, "trigger", "gpio_line",
              "missing (offset or line name)");
    r.Get(trigger, "trigger", "active_low", &c.button.active_low);
    r.Get(trigger, "trigger", "bias", &c.button.bias);
    r.GetNumber(trigger, "trigger", "debounce_ms", {0, 10000}, &c.button.debounce_ms);
    if (const std::string problem = c.button.Check(); !problem.empty()) {
      const char* key = problem.find("bias") != std::string::npos       ? "bias"
                        : problem.find("debounce") != std::string::npos ? "debounce_ms"
                                                                        : "gpio_line";
      r.Require(false, trigger, "trigger", key, problem);
    }
  }

  const auto* keyframes = r.Table("keyframes");
  r.GetNumber(keyframes, "keyframes", "parallax_deg", {0.0, 90.0}, &c.gate.parallax_deg);
  r.GetNumber(keyframes, "keyframes", "min_tracks", {8, kMaxCount}, &c.gate.min_tracks);
  r.GetNumber(keyframes, "keyframes", "min_inliers", {8, kMaxCount}, &c.gate.min_inliers);
  r.GetNumber(keyframes, "keyframes", "max_tries", {1, 100}, &c.max_b_tries);
  // An hour of tracking for one capture is already absurd; 1e300 ended every capture at once.
  r.GetNumber(keyframes, "keyframes", "timeout_s", {0.0, 3600.0}, &c.keyframe_timeout_s);
  r.Require(c.keyframe_timeout_s > 0, keyframes, "keyframes", "timeout_s", "must be > 0");

  const auto* recon = r.Table("recon");
  r.GetChoice(recon, "recon", "sift", ParseSiftImpl, SiftImplName,
              "an implementation (own or opencv)", &c.recon.sift.impl);
  r.GetNumber(recon, "recon", "max_features", {0, kMaxCount}, &c.recon.sift.max_features);
  r.GetNumber(recon, "recon", "contrast_threshold", {0.0, 1.0}, &c.recon.sift.contrast_threshold);
  r.GetNumber(recon, "recon", "match_ratio", {0.0, 1.0}, &c.recon.match.ratio);
  r.GetNumber(recon, "recon", "ransac_threshold_px", {0.0, 100.0},
              &c.recon.two_view.ransac_threshold_px);
  r.GetNumber(recon, "recon", "min_inliers", {8, kMaxCount}, &c.recon.two_view.min_inliers);
  r.GetNumber(recon, "recon", "max_depth_ratio", {0.0, 1e6}, &c.recon.mesh.max_depth_ratio);
  r.Get(recon, "recon", "refine_points", &c.recon.refinement.enabled);
  r.GetNumber(recon, "recon", "min_parallax_deg", {0.0, 90.0},
              &c.recon.two_view.min_median_triangulation_angle_deg);
  if (const std::string problem = c.recon.Check(); !problem.empty()) {
    // The option names in Check() messages are the struct's; map the common ones to keys.
    const std::string field = problem.substr(0, problem.find(':'));
    const std::string key = field == "ratio"                                ? "match_ratio"
                            : field == "min_median_triangulation_angle_deg" ? "min_parallax_deg"
                                                                            : field;
    r.Require(false, recon, "recon", key.c_str(), problem.substr(problem.find(':') + 2));
  }

  const auto* mesh = r.Table("mesh");
  r.GetChoice(mesh, "mesh", "mode", ParseMeshMode, MeshModeName, "a mesh mode (dense or sparse)",
              &c.recon.mesh_mode);
  r.GetNumber(mesh, "mesh", "vertex_budget", {16, 1000000}, &c.recon.dense_mesh.vertex_budget);

  // The gate applies the reconstruction's own tests (one notion of "enough parallax").
  c.gate.two_view = c.recon.two_view;
  if (const std::string problem = c.gate.Check(); !problem.empty()) {
    const std::string key = problem.substr(0, problem.find(':'));
    r.Require(false, keyframes, "keyframes", key.c_str(), problem.substr(problem.find(':') + 2));
  }

  const auto* walk = r.Table("walk");
  c.walk.gate = c.gate;
  r.GetNumber(walk, "walk", "parallax_deg", {0.0, 90.0}, &c.walk.gate.parallax_deg);
  r.GetNumber(walk, "walk", "max_keyframes", {2, 100000}, &c.walk.max_keyframes);
  r.GetNumber(walk, "walk", "timeout_s", {0.0, 86400.0}, &c.walk.timeout_s);
  r.Require(c.walk.timeout_s > 0, walk, "walk", "timeout_s", "must be > 0");
  r.GetChoice(
      walk, "walk", "mesh",
      [](const std::string& word) -> std::optional<bool> {
        if (word == "dense") return true;
        if (word == "sparse") return false;
        return std::nullopt;
      },
      [](bool dense) { return dense ? "dense" : "sparse"; }, "a mesh mode (dense or sparse)",
      &c.walk.dense_mesh);
  r.GetNumber(walk, "walk", "max_mesh_parts", {1, 10000}, &c.walk.max_mesh_parts);
  r.Get(walk, "walk", "refine", &c.walk.refine);
  if (const std::string problem = c.walk.gate.Check(); !problem.empty()) {
    r.Require(false, walk, "walk", "parallax_deg", problem.substr(problem.find(':') + 2));
  }

  const auto* scale = r.Table("scale");
  r.GetChoice(scale, "scale", "source", ParseScaleSource, ScaleSourceName,
              "a scale source (none, odometry, floor or auto)", &c.scale.source);
  r.GetNumber(scale, "scale", "camera_height_m", {0.0, 100.0}, &c.scale.camera_height_m);
  r.GetNumber(scale, "scale", "camera_pitch_deg", {-90.0, 90.0}, &c.scale.camera_pitch_deg);
  r.GetNumber(scale, "scale", "min_baseline_m", {0.0, 100.0}, &c.scale.min_baseline_m);
  r.GetNumber(scale, "scale", "max_odom_age_s", {0.0, 60.0}, &c.max_odom_age_s);
  using Clock = DaemonConfig::OdometryClock;
  r.GetChoice(
      scale, "scale", "odometry_clock",
      [](const std::string& word) -> std::optional<Clock> {
        if (word == "realtime") return Clock::kRealtime;
        if (word == "camera") return Clock::kCamera;
        return std::nullopt;
      },
      [](Clock clock) { return clock == Clock::kCamera ? "camera" : "realtime"; },
      "a clock (realtime or camera)", &c.odometry_clock);
  if (const std::string problem = c.scale.Check(); !problem.empty()) {
    const std::string key = problem.substr(0, problem.find(':'));
    r.Require(false, scale, "scale", key.c_str(), problem.substr(problem.find(':') + 2));
  }

  const auto* spool = r.Table("spool");
  r.GetPath(spool, "spool", "dir", c.config_dir, &c.spool_dir);
  r.GetNumber(spool, "spool", "max_entries", {0, kMaxCount}, &c.spool_max_entries);

  const auto* hooks = r.Table("hooks");
  for (auto [key, argv] :
       {std::pair{"on_entry", &c.hooks.on_entry}, std::pair{"on_failure", &c.hooks.on_failure}}) {
    std::string command;
    r.Get(hooks, "hooks", key, &command);
    *argv = SplitHookCommand(command);
    if (argv->empty()) continue;
    // No shell and no PATH search: the program is a path, relative to the config's folder.
    const std::filesystem::path program((*argv)[0]);
    (*argv)[0] = (program.is_absolute() ? program : (c.config_dir / program).lexically_normal());
    r.Require(::access((*argv)[0].c_str(), X_OK) == 0, hooks, "hooks", key,
              "'" + (*argv)[0] +
                  "' is not an executable file (a program's path, run without a "
                  "shell; the entry's folder or the reason is its last argument)");
  }
  r.GetNumber(hooks, "hooks", "timeout_s", {0.1, 3600.0}, &c.hooks.timeout_s);

  const auto* web = r.Table("web");
  std::string listen = c.web.listen_host + ":" + std::to_string(c.web.listen_port);
  r.Get(web, "web", "listen", &listen);
  r.Require(ParseListenAddress(listen, &c.web.listen_host, &c.web.listen_port), web, "web",
            "listen", "'" + listen + "' is not HOST:PORT (an IPv4 address, port 1 to 65535)");
  r.GetPath(web, "web", "token_file", c.config_dir, &c.web.token_file);
  r.GetPath(web, "web", "static_dir", c.config_dir, &c.web.static_dir);
  r.GetPath(web, "web", "three_dir", c.config_dir, &c.web.three_dir);

  const auto* log = r.Table("log");
  r.Get(log, "log", "level", &c.log_level);
  static const std::set<std::string> kLevels{"trace", "debug", "info", "warn", "error"};
  r.Require(kLevels.contains(c.log_level), log, "log", "level",
            "must be one of trace, debug, info, warn, error");

  r.CheckTopLevel();
  return c;
}

DaemonConfig LoadDaemonConfig(const std::filesystem::path& path) {
  std::string error;
  const std::optional<std::string> text = ReadTextFile(path, kMaxConfigFileBytes, &error);
  if (!text) throw ConfigError(error);
  return ParseDaemonConfig(*text, path);
}

}  // namespace mm
