#include "app/config.h"

#include <gtest/gtest.h>
#include <toml++/toml.h>

#include <fstream>
#include <map>
#include <sstream>
#include <variant>

#include "capture/source_uri.h"
#include "tests/support/read_file.h"

namespace mm {
namespace {

const std::filesystem::path kExample =
    std::filesystem::path(MM_SOURCE_DIR) / "systemd/monomeshd.example.toml";

void ExpectError(const std::string& text, const std::string& needle) {
  try {
    ParseDaemonConfig(text, "/etc/monomesh/d.toml");
    FAIL() << "expected ConfigError for:\n" << text;
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find(needle), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("/etc/monomesh/d.toml"), std::string::npos) << e.what();
  }
}

constexpr const char* kMinimal = "[camera]\nuri = \"replay:data\"\ncalibration = \"c.toml\"\n";

using test::ReadFile;

using Value = std::variant<bool, int64_t, double, std::string>;

// The code's default of every key ("" for the required camera keys, which have none).
std::map<std::string, Value> CodeDefaults() {
  const DaemonConfig d = ParseDaemonConfig(kMinimal, "/x/d.toml");
  const GpioButtonOptions button;
  return {
      {"control.socket", d.control_socket.string()},
      {"control.group", d.control_group},
      {"control.mode", int64_t{d.control_mode}},
      {"trigger.gpio_chip", std::string()},  // No button.
      {"trigger.gpio_line", button.line},
      {"trigger.active_low", button.active_low},
      {"trigger.bias", button.bias},
      {"trigger.debounce_ms", int64_t{button.debounce_ms}},
      {"trigger.long_press_ms", int64_t{d.long_press_ms}},
      {"keyframes.parallax_deg", d.gate.parallax_deg},
      {"keyframes.min_tracks", int64_t{d.gate.min_tracks}},
      {"keyframes.min_inliers", int64_t{d.gate.min_inliers}},
      {"keyframes.max_tries", int64_t{d.max_b_tries}},
      {"keyframes.timeout_s", d.keyframe_timeout_s},
      {"recon.min_parallax_deg", d.recon.two_view.min_median_triangulation_angle_deg},
      {"recon.sift", std::string(SiftImplName(d.recon.sift.impl))},
      {"recon.max_features", int64_t{d.recon.sift.max_features}},
      {"recon.contrast_threshold", d.recon.sift.contrast_threshold},
      {"recon.match_ratio", d.recon.match.ratio},
      {"recon.ransac_threshold_px", d.recon.two_view.ransac_threshold_px},
      {"recon.min_inliers", int64_t{d.recon.two_view.min_inliers}},
      {"recon.max_depth_ratio", d.recon.mesh.max_depth_ratio},
      {"recon.refine_points", d.recon.refinement.enabled},
      {"mesh.mode", std::string(MeshModeName(d.recon.mesh_mode))},
      {"mesh.vertex_budget", int64_t{d.recon.dense_mesh.vertex_budget}},
      {"walk.parallax_deg", d.walk.gate.parallax_deg},
      {"walk.max_keyframes", int64_t{d.walk.max_keyframes}},
      {"walk.timeout_s", d.walk.timeout_s},
      {"walk.mesh", std::string(d.walk.dense_mesh ? "dense" : "sparse")},
      {"walk.max_mesh_parts", int64_t{d.walk.max_mesh_parts}},
      {"walk.refine", d.walk.refine},
      {"scale.source", std::string(ScaleSourceName(d.scale.source))},
      {"scale.camera_height_m", d.scale.camera_height_m},
      {"scale.camera_pitch_deg", d.scale.camera_pitch_deg},
      {"scale.min_baseline_m", d.scale.min_baseline_m},
      {"scale.max_odom_age_s", d.max_odom_age_s},
      {"scale.odometry_clock", std::string("realtime")},
      {"spool.dir", d.spool_dir.string()},
      {"spool.max_entries", int64_t{d.spool_max_entries}},
      {"hooks.on_entry", std::string()},  // No hook.
      {"hooks.on_failure", std::string()},
      {"hooks.timeout_s", d.hooks.timeout_s},
      {"web.listen", d.web.listen_host + ":" + std::to_string(d.web.listen_port)},
      {"web.token_file", d.web.token_file.string()},
      {"web.static_dir", d.web.static_dir.string()},
      {"web.three_dir", d.web.three_dir.string()},
      {"log.level", d.log_level},
  };
}

std::string Text(const Value& v) {
  return std::visit(
      [](const auto& x) {
        std::ostringstream s;
        s << std::boolalpha << x;
        return s.str();
      },
      v);
}

// The example's value of a key, as the type the code's default has (a float key may be
// written as an integer).
std::optional<Value> ExampleValue(const toml::table& example, const std::string& key,
                                  const Value& like) {
  const toml::node_view<const toml::node> node = example.at_path(key);
  if (!node) return std::nullopt;
  if (std::holds_alternative<bool>(like)) {
    if (auto v = node.value_exact<bool>()) return *v;
  } else if (std::holds_alternative<int64_t>(like)) {
    if (auto v = node.value_exact<int64_t>()) return *v;
  } else if (std::holds_alternative<double>(like)) {
    if (auto v = node.value<double>()) return *v;
  } else if (auto v = node.value_exact<std::string>()) {
    return *v;
  }
  return std::nullopt;
}

// The installed example documents the code: every key the parser knows is in it with the
// code's default (the camera keys, which have none, name the bundled demo), and it loads.
TEST(DaemonConfig, ExampleConfigListsEveryKeyWithTheCodesDefault) {
  const toml::table example = toml::parse_file(kExample.string());
  const std::map<std::string, Value> defaults = CodeDefaults();
  for (const std::string& key : DaemonConfigKeys()) {
    EXPECT_TRUE(example.at_path(key)) << key << " is not in " << kExample;
    if (key == "camera.uri" || key == "camera.calibration") continue;
    const auto it = defaults.find(key);
    ASSERT_NE(it, defaults.end()) << key << ": the test has no default for it";
    const std::optional<Value> got = ExampleValue(example, key, it->second);
    ASSERT_TRUE(got.has_value()) << key << ": missing or of the wrong type in " << kExample;
    EXPECT_EQ(Text(*got), Text(it->second)) << key << " in " << kExample;
  }
  EXPECT_EQ(defaults.size() + 2, DaemonConfigKeys().size());
  const DaemonConfig c = LoadDaemonConfig(kExample);
  EXPECT_FALSE(c.button_enabled);
  EXPECT_EQ(c.camera_uri, "replay:/usr/share/monomesh/demo/tum_office?rate=realtime&loop=1");
}

// The example documents every camera scheme the capture registry knows and both calibration
// formats.
TEST(DaemonConfig, ExampleConfigDocumentsEverySchemeAndCalibrationFormat) {
  const std::string text = ReadFile(kExample);
  ASSERT_FALSE(FrameSourceSchemes().empty());
  for (const std::string& scheme : FrameSourceSchemes()) {
    // A comment line naming the scheme: "#", blanks, "<scheme>:".
    bool documented = false;
    for (size_t at = text.find(scheme + ":"); at != std::string::npos && !documented;
         at = text.find(scheme + ":", at + 1)) {
      size_t p = at;
      while (p > 0 && (text[p - 1] == ' ' || text[p - 1] == '\t')) --p;
      documented = p < at && p > 0 && text[p - 1] == '#';
    }
    EXPECT_TRUE(documented) << "scheme " << scheme << " is not documented in " << kExample;
  }
  EXPECT_NE(text.find("TOML"), std::string::npos);
  EXPECT_NE(text.find("Calib_Results.m"), std::string::npos);
}

// One source of truth for where the daemon writes: the default spool is in the unit's
// StateDirectory, and the unit names no other writable path.
TEST(DaemonConfig, DefaultSpoolIsInTheUnitsStateDirectory) {
  const std::string unit =
      ReadFile(std::filesystem::path(MM_SOURCE_DIR) / "systemd/monomeshd.service");
  const std::string key = "\nStateDirectory=";
  const size_t at = unit.find(key);
  ASSERT_NE(at, std::string::npos) << unit;
  const size_t begin = at + key.size();
  const std::string name = unit.substr(begin, unit.find('\n', begin) - begin);
  ASSERT_FALSE(name.empty());
  const std::filesystem::path state = std::filesystem::path("/var/lib") / name;
  const DaemonConfig d = ParseDaemonConfig(kMinimal, "/x/d.toml");
  EXPECT_EQ(d.spool_dir.parent_path(), state);
  EXPECT_EQ(unit.find("ReadWritePaths="), std::string::npos);
}

TEST(DaemonConfig, GpioButtonIsOptional) {
  EXPECT_FALSE(ParseDaemonConfig(kMinimal, "/x/d.toml").button_enabled);
  const DaemonConfig c =
      ParseDaemonConfig(std::string(kMinimal) +
                            "[trigger]\ngpio_chip = \"pinctrl-bcm2711\"\ngpio_line = \"GPIO17\"\n"
                            "active_low = true\nbias = \"pull-up\"\ndebounce_ms = 50\n",
                        "/x/d.toml");
  EXPECT_TRUE(c.button_enabled);
  EXPECT_EQ(c.button.chip, "pinctrl-bcm2711");
  EXPECT_EQ(c.button.line, "GPIO17");
  EXPECT_EQ(c.button.bias, "pull-up");
  EXPECT_EQ(c.button.debounce_ms, 50);
}

TEST(DaemonConfig, RelativePathsResolveAgainstConfigFolder) {
  const DaemonConfig c = ParseDaemonConfig(kMinimal, "/etc/monomesh/d.toml");
  EXPECT_EQ(c.calibration, std::filesystem::path("/etc/monomesh/c.toml"));
  EXPECT_EQ(c.camera_uri, "replay:data");
}

TEST(DaemonConfig, ErrorsNameTheKey) {
  ExpectError(std::string(kMinimal) + "[spool]\ndirr = \"x\"\n", "spool.dirr");
  ExpectError(std::string(kMinimal) + "[spol]\n", "'spol': unknown table");
  ExpectError(std::string(kMinimal) + "[keyframes]\nparallax_deg = 0\n", "keyframes.parallax_deg");
  ExpectError(std::string(kMinimal) + "[keyframes]\nb_after_frames = 2\n",
              "keyframes.b_after_frames': unknown key");
  ExpectError(std::string(kMinimal) + "[keyframes]\ntimeout_s = \"soon\"\n",
              "keyframes.timeout_s': wrong type");
  ExpectError(std::string(kMinimal) + "[recon]\nmatch_ratio = 1.5\n", "recon.match_ratio");
  ExpectError(std::string(kMinimal) + "[recon]\nsift = \"surf\"\n", "recon.sift");
  ExpectError(std::string(kMinimal) + "[mesh]\nmode = \"dense2\"\n", "mesh.mode");
  ExpectError(std::string(kMinimal) + "[mesh]\nvertex_budget = 4294967297\n", "mesh.vertex_budget");
  ExpectError(std::string(kMinimal) + "[recon]\nrefine_points = 1\n",
              "recon.refine_points': wrong type");
  EXPECT_FALSE(
      ParseDaemonConfig(std::string(kMinimal) + "[recon]\nrefine_points = false\n", "/x/d.toml")
          .recon.refinement.enabled);
  // One notion of parallax: the gate's target may not be below the reconstruction's minimum.
  ExpectError(std::string(kMinimal) + "[recon]\nmin_parallax_deg = 2.5\n",
              "keyframes.parallax_deg");
  ExpectError(std::string(kMinimal) + "[recon]\nmin_parallax_deg = -1\n", "recon.min_parallax_deg");
  ExpectError(std::string(kMinimal) + "[keyframes]\nmax_tries = 0\n", "keyframes.max_tries");
  {
    const DaemonConfig c = ParseDaemonConfig(std::string(kMinimal) +
                                                 "[keyframes]\nparallax_deg = 3.0\nmax_tries = 4\n"
                                                 "[recon]\nmin_parallax_deg = 2.0\n",
                                             "/x/d.toml");
    EXPECT_EQ(c.gate.parallax_deg, 3.0);
    EXPECT_EQ(c.max_b_tries, 4);
    EXPECT_EQ(c.recon.two_view.min_median_triangulation_angle_deg, 2.0);
    // The gate applies the reconstruction's own tests and thresholds.
    EXPECT_EQ(c.gate.two_view.min_median_triangulation_angle_deg, 2.0);
  }
  ExpectError(std::string(kMinimal) + "[log]\nlevel = \"loud\"\n", "log.level");
  ExpectError("[camera]\ncalibration = \"c.toml\"\n", "camera.uri");
  ExpectError("[camera\n", "not valid TOML");
  ExpectError(std::string(kMinimal) + "[trigger]\ngpio_chip = \"gpiochip0\"\nbias = \"sideways\"\n",
              "trigger.bias");
  ExpectError(std::string(kMinimal) + "[trigger]\ngpio_chip = \"gpiochip0\"\ndebounce_ms = -5\n",
              "trigger.debounce_ms");
}

// Every number is checked for its type and range: nothing wraps, nothing non-finite or absurd.
TEST(DaemonConfig, NumbersOutOfRangeAreErrorsNotWrapped) {
  const std::string m(kMinimal);
  // 4294967297 = 2^32 + 1 became 1 through a cast to int.
  ExpectError(m + "[spool]\nmax_entries = 4294967297\n", "spool.max_entries': expected an integer");
  ExpectError(m + "[spool]\nmax_entries = -1\n", "spool.max_entries");
  ExpectError(m + "[spool]\nmax_entries = 2.5\n", "spool.max_entries");
  ExpectError(m + "[recon]\nmax_features = 4294967297\n", "recon.max_features");
  ExpectError(m + "[recon]\nmin_inliers = 4294967304\n", "recon.min_inliers");
  ExpectError(m + "[keyframes]\nmin_tracks = 4294967336\n", "keyframes.min_tracks");
  ExpectError(m + "[keyframes]\nmin_inliers = 4294967334\n", "keyframes.min_inliers");
  ExpectError(m + "[keyframes]\nmax_tries = 4294967298\n", "keyframes.max_tries");
  ExpectError(m + "[trigger]\ngpio_chip = \"gpiochip0\"\ngpio_line = \"4\"\n"
                  "debounce_ms = 4294967326\n",
              "trigger.debounce_ms");
  ExpectError(m + "[keyframes]\ntimeout_s = 1e300\n", "keyframes.timeout_s': expected a finite");
  ExpectError(m + "[keyframes]\ntimeout_s = inf\n", "keyframes.timeout_s");
  ExpectError(m + "[keyframes]\ntimeout_s = nan\n", "keyframes.timeout_s");
  ExpectError(m + "[keyframes]\nparallax_deg = inf\n", "keyframes.parallax_deg");
  ExpectError(m + "[keyframes]\nparallax_deg = nan\n", "keyframes.parallax_deg");
  ExpectError(m + "[recon]\nmin_parallax_deg = nan\n", "recon.min_parallax_deg");
  ExpectError(m + "[recon]\nmatch_ratio = nan\n", "recon.match_ratio");
  ExpectError(m + "[recon]\ncontrast_threshold = inf\n", "recon.contrast_threshold");
  ExpectError(m + "[recon]\nransac_threshold_px = 1e300\n", "recon.ransac_threshold_px");
  ExpectError(m + "[recon]\nmax_depth_ratio = inf\n", "recon.max_depth_ratio");
  ExpectError(m + "[recon]\nmax_features = \"many\"\n", "recon.max_features': wrong type");
  // In range: integral floats count as integers, integers as floats.
  const DaemonConfig c = ParseDaemonConfig(
      m + "[spool]\nmax_entries = 1e3\n[keyframes]\ntimeout_s = 10\n", "/x/d.toml");
  EXPECT_EQ(c.spool_max_entries, 1000);
  EXPECT_EQ(c.keyframe_timeout_s, 10.0);
}

// A hook is a program's path and its words (no shell); relative to the config's folder; a
// program that is not there, or not executable, is an error naming the key.
TEST(DaemonConfig, HooksAreProgramsWithArguments) {
  const DaemonConfig c = ParseDaemonConfig(
      std::string(kMinimal) +
          "[hooks]\non_entry = \"/bin/sh  -c \t'echo'\"\non_failure = \"\"\ntimeout_s = 2.5\n",
      "/etc/monomesh/d.toml");
  EXPECT_EQ(c.hooks.on_entry, (std::vector<std::string>{"/bin/sh", "-c", "'echo'"}));
  EXPECT_TRUE(c.hooks.on_failure.empty());
  EXPECT_EQ(c.hooks.timeout_s, 2.5);
  ExpectError(std::string(kMinimal) + "[hooks]\non_entry = \"upload.sh x\"\n",
              "hooks.on_entry': '/etc/monomesh/upload.sh' is not an executable file");
  ExpectError(std::string(kMinimal) + "[hooks]\non_failure = \"/etc/passwd\"\n",
              "hooks.on_failure");
  ExpectError(std::string(kMinimal) + "[hooks]\ntimeout_s = 0\n", "hooks.timeout_s");
  ExpectError(std::string(kMinimal) + "[hooks]\non_entry = [\"/bin/true\"]\n",
              "hooks.on_entry': wrong type");
}

// [web] listen is an IPv4 address and a port (the service binds it before any name service);
// paths are relative to the config's folder.
TEST(DaemonConfig, WebListenIsAnAddressAndAPort) {
  const DaemonConfig c = ParseDaemonConfig(
      std::string(kMinimal) + "[web]\nlisten = \"0.0.0.0:8443\"\ntoken_file = \"token\"\n",
      "/etc/monomesh/d.toml");
  EXPECT_EQ(c.web.listen_host, "0.0.0.0");
  EXPECT_EQ(c.web.listen_port, 8443);
  EXPECT_EQ(c.web.token_file, "/etc/monomesh/token");
  for (const char* bad : {"localhost:8080", "127.0.0.1", "127.0.0.1:0", "127.0.0.1:65536",
                          "127.0.0.1:80x", ":8080", "127.0.0.1:"}) {
    ExpectError(std::string(kMinimal) + "[web]\nlisten = \"" + bad + "\"\n", "web.listen");
  }
}

TEST(DaemonConfig, ControlSocketGroupAndMode) {
  const DaemonConfig d = ParseDaemonConfig(kMinimal, "/x/d.toml");
  EXPECT_EQ(d.control_group, "monomesh");
  EXPECT_EQ(d.control_mode, 0660);
  const DaemonConfig c = ParseDaemonConfig(
      std::string(kMinimal) + "[control]\ngroup = \"\"\nmode = 0o640\n", "/x/d.toml");
  EXPECT_EQ(c.control_group, "");
  EXPECT_EQ(c.control_mode, 0640);
  // Only a group the file names is required to exist (the daemon warns for the default).
  EXPECT_FALSE(d.control_group_given);
  EXPECT_TRUE(c.control_group_given);
  EXPECT_FALSE(ParseDaemonConfig(std::string(kMinimal) + "[control]\nmode = 0o640\n", "/x/d.toml")
                   .control_group_given);
  ExpectError(std::string(kMinimal) + "[control]\nmode = 0o1777\n", "control.mode': expected");
  ExpectError(std::string(kMinimal) + "[control]\nmode = -1\n", "control.mode");
  ExpectError(std::string(kMinimal) + "[control]\nmode = \"0660\"\n", "control.mode");
  ExpectError(std::string(kMinimal) + "[control]\ngroup = 5\n", "control.group': wrong type");
}

TEST(DaemonConfig, SocketPathLongerThanASocketAddressIsAnError) {
  ExpectError(
      std::string(kMinimal) + "[control]\nsocket = \"/run/" + std::string(120, 's') + "\"\n",
      "control.socket");
}

}  // namespace
}  // namespace mm
