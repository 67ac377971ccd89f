// Google Benchmark: the Highway matcher (MatchDescriptors, both directions in one pass, ratio +
// mutual) against cv::BFMatcher::knnMatch (k = 2 forward + k = 1 backward, as a mutual ratio
// matcher needs), on the same SIFT descriptors of two TUM keyframes, one thread.
// Run: build/default/recon/recon_matcher_bench [--benchmark_format=json]

#include <benchmark/benchmark.h>

#include <filesystem>
#include <opencv2/core/utility.hpp>
#include <opencv2/features2d.hpp>
#include <opencv2/imgcodecs.hpp>

#include "recon/features.h"

namespace {

struct Descriptors {
  cv::Mat a, b;
};

const Descriptors& Load() {
  static const Descriptors d = [] {
    cv::setNumThreads(1);
    const std::filesystem::path shared = std::filesystem::path(MM_SOURCE_DIR).parent_path() /
                                         "shared/data/tum_fr3_long_office_household/keyframes_1hz";
    auto pick = [&](const char* name) {
      return cv::imread((shared / name).string(), cv::IMREAD_GRAYSCALE);
    };
    cv::Mat ia = pick("1341847980.722988.png"), ib = pick("1341847981.726650.png");
    Descriptors out;
    if (ia.empty() || ib.empty()) {
      // No shared data: random SIFT-like integer descriptors of the same size.
      cv::RNG rng(1);
      out.a.create(2000, 128, CV_32F);
      out.b.create(2000, 128, CV_32F);
      rng.fill(out.a, cv::RNG::UNIFORM, 0, 60);
      rng.fill(out.b, cv::RNG::UNIFORM, 0, 60);
      out.a.convertTo(out.a, CV_8U);
      out.a.convertTo(out.a, CV_32F);
      out.b.convertTo(out.b, CV_8U);
      out.b.convertTo(out.b, CV_32F);
      return out;
    }
    mm::SiftOptions sift;
    out.a = mm::ExtractSift(ia, sift).descriptors;
    out.b = mm::ExtractSift(ib, sift).descriptors;
    return out;
  }();
  return d;
}

void BM_HighwayMatcher(benchmark::State& state) {
  const Descriptors& d = Load();
  size_t n = 0;
  for (auto _ : state) {
    const auto m = mm::MatchDescriptors(d.a, d.b, {0.8, true});
    n = m.size();
    benchmark::DoNotOptimize(n);
  }
  state.counters["rows_a"] = d.a.rows;
  state.counters["rows_b"] = d.b.rows;
  state.counters["matches"] = static_cast<double>(n);
}
BENCHMARK(BM_HighwayMatcher)->Unit(benchmark::kMillisecond);

void BM_ScalarMatcher(benchmark::State& state) {
  const Descriptors& d = Load();
  for (auto _ : state) {
    const auto m = mm::MatchDescriptorsScalar(d.a, d.b, {0.8, true});
    benchmark::DoNotOptimize(m.size());
  }
}
BENCHMARK(BM_ScalarMatcher)->Unit(benchmark::kMillisecond)->Iterations(3);

void BM_OpenCvBfKnnMatch(benchmark::State& state) {
  const Descriptors& d = Load();
  cv::setNumThreads(1);
  cv::BFMatcher matcher(cv::NORM_L2);
  size_t n = 0;
  for (auto _ : state) {
    std::vector<std::vector<cv::DMatch>> ab, ba;
    matcher.knnMatch(d.a, d.b, ab, 2);
    matcher.knnMatch(d.b, d.a, ba, 1);
    n = ab.size() + ba.size();
    benchmark::DoNotOptimize(n);
  }
}
BENCHMARK(BM_OpenCvBfKnnMatch)->Unit(benchmark::kMillisecond);

void BM_OpenCvBfKnnMatchForwardOnly(benchmark::State& state) {
  const Descriptors& d = Load();
  cv::setNumThreads(1);
  cv::BFMatcher matcher(cv::NORM_L2);
  for (auto _ : state) {
    std::vector<std::vector<cv::DMatch>> ab;
    matcher.knnMatch(d.a, d.b, ab, 2);
    benchmark::DoNotOptimize(ab.size());
  }
}
BENCHMARK(BM_OpenCvBfKnnMatchForwardOnly)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
