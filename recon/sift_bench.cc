// Google Benchmark: our SIFT (SiftImpl::kOwn, Highway kernels) against OpenCV 4.6's cv::SIFT on
// the same 640x480 TUM keyframe, default SiftOptions, one thread; and the Highway blur kernel
// against its scalar reference on the doubled first octave (1280x960).
// Run: build/default/recon/recon_sift_bench [--benchmark_format=json]

#include <benchmark/benchmark.h>

#include <hwy/targets.h>
#include <algorithm>
#include <filesystem>
#include <opencv2/core/utility.hpp>
#include <opencv2/imgcodecs.hpp>

#include "recon/features.h"
#include "recon/sift.h"

namespace {

const cv::Mat& Image() {
  static const cv::Mat img = [] {
    cv::setNumThreads(1);
    return cv::imread(
        (std::filesystem::path(MM_SOURCE_DIR) / "data/tum_office/rgb/1341847980.722988.png")
            .string(),
        cv::IMREAD_GRAYSCALE);
  }();
  return img;
}

void RunSift(benchmark::State& state, mm::SiftImpl impl) {
  const cv::Mat& img = Image();
  mm::SiftOptions options;
  options.impl = impl;
  size_t n = 0;
  for (auto _ : state) {
    const mm::Features f = mm::ExtractSift(img, options);
    n = f.keypoints.size();
    benchmark::DoNotOptimize(n);
  }
  state.counters["keypoints"] = static_cast<double>(n);
}

void BM_OwnSift(benchmark::State& state) { RunSift(state, mm::SiftImpl::kOwn); }
BENCHMARK(BM_OwnSift)->Unit(benchmark::kMillisecond);

void BM_OpenCvSift(benchmark::State& state) { RunSift(state, mm::SiftImpl::kOpenCv); }

// The own SIFT restricted to each compiled Highway target (e.g. SSE4 as a proxy for 128-bit NEON).
void BM_OwnSiftPerTarget(benchmark::State& state) {
  const auto target = static_cast<int64_t>(state.range(0));
  const std::vector<int64_t> targets = hwy::SupportedAndGeneratedTargets();
  if (std::find(targets.begin(), targets.end(), target) == targets.end()) {
    state.SkipWithError("target not supported");
    return;
  }
  hwy::SetSupportedTargetsForTest(target);
  RunSift(state, mm::SiftImpl::kOwn);
  hwy::SetSupportedTargetsForTest(0);
  state.SetLabel(hwy::TargetName(target));
}
BENCHMARK(BM_OwnSiftPerTarget)
    ->Arg(HWY_SSE4)
    ->Arg(HWY_AVX2)
    ->Arg(HWY_AVX3)
    ->Unit(benchmark::kMillisecond);
BENCHMARK(BM_OpenCvSift)->Unit(benchmark::kMillisecond);

mm::sift::Plane DoubledFrame() {
  const cv::Mat& img = Image();
  mm::sift::Plane p(2 * img.cols, 2 * img.rows);
  for (int y = 0; y < p.h; ++y) {
    for (int x = 0; x < p.w; ++x) p.Row(y)[x] = img.at<uint8_t>(y / 2, x / 2);
  }
  return p;
}

// One Gaussian blur of the doubled frame, sigma = range(0) / 1000, by `blur` (Highway or the
// scalar reference).
template <typename BlurFn>
void RunBlur(benchmark::State& state, BlurFn blur) {
  const mm::sift::Plane src = DoubledFrame();
  const std::vector<float> k =
      mm::sift::GaussianHalfKernel(static_cast<double>(state.range(0)) / 1000);
  mm::sift::Plane dst;
  for (auto _ : state) {
    blur(src, k, &dst);
    benchmark::DoNotOptimize(dst.px.get());
  }
}
void BM_BlurHighway(benchmark::State& state) {
  RunBlur(state, [](const mm::sift::Plane& src, const std::vector<float>& k,
                    mm::sift::Plane* dst) { mm::sift::Blur(src, k, dst); });
}
void BM_BlurScalar(benchmark::State& state) { RunBlur(state, &mm::sift::BlurScalar); }
BENCHMARK(BM_BlurHighway)->Arg(1226)->Arg(3090)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_BlurScalar)->Arg(1226)->Arg(3090)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
