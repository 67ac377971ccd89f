// Frame undistortion: mm::Undistorter (Bouguet model maps, fixed point) next to OpenCV on the
// same frame: cv::undistort (builds its maps on every call) and cv::remap with OpenCV's own
// initUndistortRectifyMap tables (CV_16SC2, built once). Not a ctest; run
//   build/default/calib/calib_undistort_bench

#include <benchmark/benchmark.h>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "calib/opencv_camera.h"
#include "calib/undistort.h"

namespace mm {
namespace {

// An EuRoC-like lens (k1 = -0.28) scaled to the frame size.
BouguetCamera BenchCamera(int width, int height) {
  const double s = width / 752.0;
  BouguetCamera c;
  c.fc = {458.654 * s, 457.296 * s};
  c.cc = {367.215 * s, 248.375 * height / 480.0};
  c.kc = {-0.28340811, 0.07395907, 0.00019359, 1.76187114e-05, 0.0};
  c.width = width;
  c.height = height;
  return c;
}

cv::Mat BenchFrame(int width, int height, int channels) {
  cv::Mat frame(height, width, CV_8UC(channels));
  cv::RNG rng(1);
  rng.fill(frame, cv::RNG::UNIFORM, 0, 255);
  return frame;
}

void SetCounters(benchmark::State& state, int width, int height) {
  state.SetItemsProcessed(state.iterations());
  state.counters["Mpix/s"] = benchmark::Counter(static_cast<double>(width) * height / 1e6,
                                                benchmark::Counter::kIsIterationInvariantRate);
}

void BM_MmUndistorter(benchmark::State& state) {
  const int w = static_cast<int>(state.range(0)), h = static_cast<int>(state.range(1));
  const Undistorter u(BenchCamera(w, h));
  const cv::Mat frame = BenchFrame(w, h, static_cast<int>(state.range(2)));
  for (auto _ : state) {
    cv::Mat out = u.Apply(frame);
    benchmark::DoNotOptimize(out.data);
  }
  SetCounters(state, w, h);
}

void BM_CvUndistort(benchmark::State& state) {
  const int w = static_cast<int>(state.range(0)), h = static_cast<int>(state.range(1));
  const OpenCvCamera o = ToOpenCv(BenchCamera(w, h));
  const cv::Mat frame = BenchFrame(w, h, static_cast<int>(state.range(2)));
  cv::Mat out;
  for (auto _ : state) {
    cv::undistort(frame, out, o.K, o.dist);
    benchmark::DoNotOptimize(out.data);
  }
  SetCounters(state, w, h);
}

void BM_CvRemapOwnMaps(benchmark::State& state) {
  const int w = static_cast<int>(state.range(0)), h = static_cast<int>(state.range(1));
  const OpenCvCamera o = ToOpenCv(BenchCamera(w, h));
  const cv::Mat frame = BenchFrame(w, h, static_cast<int>(state.range(2)));
  cv::Mat map1, map2, out;
  cv::initUndistortRectifyMap(o.K, o.dist, cv::Mat(), o.K, o.size, CV_16SC2, map1, map2);
  for (auto _ : state) {
    cv::remap(frame, out, map1, map2, cv::INTER_LINEAR, cv::BORDER_CONSTANT);
    benchmark::DoNotOptimize(out.data);
  }
  SetCounters(state, w, h);
}

void BM_MmUndistorterBuildMaps(benchmark::State& state) {
  const int w = static_cast<int>(state.range(0)), h = static_cast<int>(state.range(1));
  const BouguetCamera c = BenchCamera(w, h);
  for (auto _ : state) {
    const Undistorter u(c);
    benchmark::DoNotOptimize(&u);
  }
}

// Args: width, height, channels (1 gray, 3 colour).
void Sizes(benchmark::internal::Benchmark* b) {
  for (const auto& [w, h] : {std::pair{640, 480}, std::pair{1280, 720}}) {
    for (int ch : {1, 3}) b->Args({w, h, ch});
  }
  b->ArgNames({"w", "h", "ch"})->Unit(benchmark::kMillisecond);
}

BENCHMARK(BM_MmUndistorter)->Apply(Sizes);
BENCHMARK(BM_CvUndistort)->Apply(Sizes);
BENCHMARK(BM_CvRemapOwnMaps)->Apply(Sizes);
BENCHMARK(BM_MmUndistorterBuildMaps)
    ->Args({640, 480})
    ->Args({1280, 720})
    ->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace mm

BENCHMARK_MAIN();
