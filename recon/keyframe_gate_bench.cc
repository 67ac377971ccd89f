// Time per frame of the keyframe gate (KLT tracking + essential and homography fits +
// rotation-compensated parallax) on one core, at 640x480 and 1280x720. Frames are a bundled
// TUM keyframe and copies shifted by a few pixels (the motion between 30 fps frames).
#include <benchmark/benchmark.h>

#include <opencv2/core/utility.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "calib/calib_io.h"
#include "recon/keyframe_gate.h"

namespace {

const std::string kData = std::string(MM_SOURCE_DIR) + "/data/tum_office/";

void BM_KeyframeGateUpdate(benchmark::State& state) {
  cv::setNumThreads(0);  // One core, as on a board busy with other work.
  const cv::Size size(static_cast<int>(state.range(0)), static_cast<int>(state.range(1)));
  cv::Mat a = cv::imread(kData + "rgb/1341847980.722988.png", cv::IMREAD_GRAYSCALE);
  cv::resize(a, a, size);
  mm::BouguetCamera camera = mm::LoadCalibration(kData + "calib.toml");
  const double s = size.width / 640.0;
  camera.fc *= s;
  camera.cc *= s;
  std::vector<cv::Mat> frames;
  for (int i = 1; i <= 8; ++i) {
    const cv::Mat shift = (cv::Mat_<double>(2, 3) << 1, 0, 1.5 * i, 0, 1, 0.5 * i);
    cv::Mat f;
    cv::warpAffine(a, f, shift, size, cv::INTER_LINEAR, cv::BORDER_REFLECT);
    frames.push_back(f);
  }
  mm::KeyframeGate gate(camera.K(), mm::KeyframeGateOptions{});
  size_t i = 0;
  for (auto _ : state) {
    if (i % frames.size() == 0) {
      state.PauseTiming();
      gate.Start(a);
      state.ResumeTiming();
    }
    benchmark::DoNotOptimize(gate.Update(frames[i % frames.size()]));
    ++i;
  }
  // The budget at 30 fps is 33.3 ms of one core per frame.
  state.counters["budget_30fps_ms"] = 1000.0 / 30.0;
}
BENCHMARK(BM_KeyframeGateUpdate)->Args({640, 480})->Args({1280, 720})->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
