// What a plain user meets on a hostile input or a meaningless command line: `monomesh` refuses
// with the exit code docs/exit_codes.md gives and a message naming the field or the option,
// never a signal and never a silently ignored option.

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "tests/support/run_command.h"
#include "tests/support/temp_dir.h"

namespace mm::test {
namespace {

namespace fs = std::filesystem;

const fs::path kSource = MM_SOURCE_DIR;
const std::string kCalib = (kSource / "data/tum_office/calib.toml").string();
const std::string kImage = (kSource / "data/tum_office/rgb/1341847980.722988.png").string();
const std::string kDataset = (kSource / "data/tum_office").string();

class CliErrors : public ::testing::Test {
 protected:
  void SetUp() override {
    ASSERT_FALSE(Monomesh().empty()) << "MONOMESH is not set (run through ctest)";
    dir_ = FreshTempDir("cli_errors");
  }
  void TearDown() override { fs::remove_all(dir_); }

  // Runs `monomesh ARGS`; expects exit `code` and `text` in what it printed.
  void Expect(const std::string& args, int code, const std::string& text) {
    int status = -1;
    const std::string out = RunCommand(Monomesh() + " " + args, &status);
    EXPECT_EQ(status, code) << args << "\n" << out;
    EXPECT_NE(out.find(text), std::string::npos) << args << "\n" << out;
  }

  fs::path dir_;
};

// The GLB: a POSITION count of 2^62 + 1, whose byte size wraps to 12 (it ended in
// SIGSEGV); and the other sizes of the fuzz corpus.
TEST_F(CliErrors, RenderRefusesAGlbWhoseSizesOverrunItsBuffersWith65) {
  const fs::path corpus = kSource / "entry/fuzz_corpus/glb";
  const std::string out = " --camera " + kCalib + " --out " + (dir_ / "v.png").string();
  Expect("render " + (corpus / "position_count_wraps.glb").string() + out, 65,
         "position_count_wraps.glb: POSITION: accessors[0].count 4611686018427387905");
  Expect("render " + (corpus / "stride_below_element.glb").string() + out, 65,
         "POSITION: bufferViews[0].byteStride 4");
  Expect("render " + (corpus / "view_buffer_missing.glb").string() + out, 65,
         "bufferViews[0].buffer 5 does not exist");
  for (const char* name : {"accessor_offset_wraps.glb", "view_offset_past_buffer.glb",
                           "index_count_wraps.glb", "no_vertices_two_indices.glb"}) {
    Expect("render " + (corpus / name).string() + out, 65, name);
  }
  EXPECT_FALSE(fs::exists(dir_ / "v.png"));
}

// kc = [1e6, 1e6, 0, 0, 1e6]: monotonic and invertible, but the image squeezed into 10 px.
TEST_F(CliErrors, ALensThatDoesNotInvertOverTheImageIsRefusedWhereItIsLoaded) {
  const fs::path calib = dir_ / "lens.toml";
  std::ofstream(calib) << "[camera]\nimage_size = [640, 480]\nfc = [535.4, 539.2]\n"
                          "cc = [320.1, 247.6]\nkc = [1e6, 1e6, 0, 0, 1e6]\n";
  const std::string field = "field 'camera.kc': the distortion is not invertible";
  Expect("undistort --calib " + calib.string() + " " + kImage + " " + (dir_ / "u.png").string(), 78,
         field);
  EXPECT_FALSE(fs::exists(dir_ / "u.png"));
  Expect("recon " + kImage + " " + kImage + " --calib " + calib.string() + " --out " +
             (dir_ / "r").string(),
         78, field);
  Expect("synth --frames 2 --calib " + calib.string() + " --out " + (dir_ / "s").string(), 78,
         field);
}

TEST_F(CliErrors, AnOptionWithoutWhatItActsWithIsAnError) {
  const std::string eval = "eval --dataset " + kDataset + " --calib " + kCalib + " ";
  Expect(eval + "--odom-noise-m 0.01", 107,
         "--odom-noise-m requires --scale odometry or --scale auto");
  Expect(eval + "--scale floor --odom-seed 3", 107, "--odom-seed requires --scale odometry");
  Expect(eval + "--scale odometry --camera-height-m 1.5", 107,
         "--camera-height-m requires --scale floor or --scale auto");
  Expect(eval + "--walk --step 2", 107, "--step requires the pair evaluation");
  Expect(eval + "--trigger-every 3", 107, "--trigger-every requires --captures");
  Expect(eval + "--parallax-deg 3", 107, "--parallax-deg requires --captures or --walk");
  Expect(eval + "--walk --mesh-mode sparse", 107, "--mesh-mode requires --captures or");
  Expect(eval + "--walk-window 5", 107, "--walk-window requires --walk");
  Expect(eval + "--captures --walk", 108, "excludes");
  Expect(eval + "--spool " + dir_.string(), 108, "excludes");
  Expect("eval --dataset " + kDataset + " --spool " + dir_.string() + " --ratio 0.7", 107,
         "--ratio requires a reconstruction");
  Expect("eval --dataset " + kDataset + " --calib " + kCalib + " --feed-log " + kCalib, 107,
         "--feed-log requires --spool");
  const std::string render = "render " + (kSource / "entry/fuzz_corpus/glb/triangle.glb").string() +
                             " --camera " + kCalib + " --out " + (dir_ / "v.png").string();
  Expect(render + " --preview --pose 1 0 0 0 0 0 0", 108, "excludes");
  Expect(render + " --preview --depth-out d.png", 108, "excludes");
  Expect(render + " --depth-scale 5000", 107, "--depth-scale requires --depth-out");
  Expect("ctl status --wait 5 --socket " + (dir_ / "none.sock").string(), 107,
         "--wait requires ctl trigger");
  Expect("ctl trigger --until entry --socket " + (dir_ / "none.sock").string(), 107,
         "--until requires ctl watch");
  Expect("ctl status --socket a.sock --config b.toml", 108, "excludes");
  Expect("feed --device /dev/null --dataset " + kDataset + " --hold-last", 107,
         "--hold-last requires --once");
  Expect("feed --device /dev/null --dataset " + kDataset + " --step --hold-first", 108, "excludes");
}

}  // namespace
}  // namespace mm::test
