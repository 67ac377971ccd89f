#include "app/config.h"

#include <gtest/gtest.h>

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

TEST(DaemonConfig, ExampleConfigLoadsWithDocumentedDefaults) {
  const DaemonConfig c = LoadDaemonConfig(kExample);
  const DaemonConfig defaults = ParseDaemonConfig(kMinimal, "/x/d.toml");
  EXPECT_EQ(c.gate.parallax_deg, defaults.gate.parallax_deg);
  EXPECT_EQ(c.gate.min_tracks, defaults.gate.min_tracks);
  EXPECT_EQ(c.gate.min_inliers, defaults.gate.min_inliers);
  EXPECT_EQ(c.max_b_tries, defaults.max_b_tries);
  EXPECT_EQ(c.recon.two_view.min_median_triangulation_angle_deg,
            defaults.recon.two_view.min_median_triangulation_angle_deg);
  EXPECT_EQ(c.keyframe_timeout_s, defaults.keyframe_timeout_s);
  EXPECT_EQ(c.recon.sift.impl, defaults.recon.sift.impl);
  EXPECT_EQ(c.recon.sift.max_features, defaults.recon.sift.max_features);
  EXPECT_EQ(c.recon.match.ratio, defaults.recon.match.ratio);
  EXPECT_EQ(c.recon.two_view.ransac_threshold_px, defaults.recon.two_view.ransac_threshold_px);
  EXPECT_EQ(c.recon.two_view.min_inliers, defaults.recon.two_view.min_inliers);
  EXPECT_EQ(c.recon.refinement.enabled, defaults.recon.refinement.enabled);
  EXPECT_EQ(c.spool_dir, defaults.spool_dir);
  EXPECT_EQ(c.spool_max_entries, defaults.spool_max_entries);
  EXPECT_EQ(c.control_socket, defaults.control_socket);
  EXPECT_EQ(c.log_level, defaults.log_level);
}

TEST(DaemonConfig, GpioButtonIsOptional) {
  EXPECT_FALSE(ParseDaemonConfig(kMinimal, "/x/d.toml").button_enabled);
  const DaemonConfig c = ParseDaemonConfig(
      std::string(kMinimal) + "[trigger]\ngpio_chip = \"pinctrl-bcm2711\"\ngpio_line = \"GPIO17\"\n"
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
  ExpectError(std::string(kMinimal) + "[keyframes]\nparallax_deg = 0\n",
              "keyframes.parallax_deg");
  ExpectError(std::string(kMinimal) + "[keyframes]\nb_after_frames = 2\n",
              "keyframes.b_after_frames': unknown key");
  ExpectError(std::string(kMinimal) + "[keyframes]\ntimeout_s = \"soon\"\n",
              "keyframes.timeout_s': wrong type");
  ExpectError(std::string(kMinimal) + "[recon]\nmatch_ratio = 1.5\n", "recon.match_ratio");
  ExpectError(std::string(kMinimal) + "[recon]\nsift = \"surf\"\n", "recon.sift");
  ExpectError(std::string(kMinimal) + "[recon]\nrefine_points = 1\n",
              "recon.refine_points': wrong type");
  EXPECT_FALSE(ParseDaemonConfig(std::string(kMinimal) + "[recon]\nrefine_points = false\n",
                                 "/x/d.toml")
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

TEST(DaemonConfig, SocketPathLongerThanASocketAddressIsAnError) {
  ExpectError(std::string(kMinimal) + "[control]\nsocket = \"/run/" + std::string(120, 's') +
                  "\"\n",
              "control.socket");
}

}  // namespace
}  // namespace mm
