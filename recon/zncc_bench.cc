// Time of one plane's warp and matching cost in the dense sweep (recon/plane_warp.h,
// recon/zncc.h) at the sweep's 320x240 (640x480 shrunk by 2), one core: each Highway pass (the
// target chosen at run time), its scalar reference, and the OpenCV path it replaced as the
// peer (for the cost: three normalized box filters and the ZNCC in full-image arithmetic; for
// the warp: warpPerspective; OpenCV's own SIMD in both). The view is A shifted by a few
// pixels, as the warped B at a plane near the true depth.
#include <benchmark/benchmark.h>

#include <Eigen/Core>
#include <opencv2/core/eigen.hpp>
#include <opencv2/core/utility.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <string>
#include <vector>

#include "recon/plane_warp.h"
#include "recon/zncc.h"

namespace {

constexpr int kRadius = 3;
constexpr float kMinVar = 1.0f;
constexpr int kScale = 64;

struct Images {
  cv::Mat view;
  mm::ZnccStatsA stats_a;
  Images() {
    cv::setNumThreads(0);
    const std::string path =
        std::string(MM_SOURCE_DIR) + "/data/tum_office/rgb/1341847980.722988.png";
    cv::Mat gray = cv::imread(path, cv::IMREAD_GRAYSCALE), a;
    cv::resize(gray, gray, cv::Size(320, 240), 0, 0, cv::INTER_AREA);
    gray.convertTo(a, CV_32F);
    const cv::Mat shift = (cv::Mat_<double>(2, 3) << 1, 0, 2.5, 0, 1, 0.5);
    cv::warpAffine(a, view, shift, a.size(), cv::INTER_LINEAR, cv::BORDER_REPLICATE);
    stats_a = mm::ComputeZnccStatsA(a, kRadius);
  }
};

const Images& TheImages() {
  static const Images images;
  return images;
}

template <bool (*Cost)(const mm::ZnccWindowsA&, std::span<const float>, float, int,
                       std::span<uint16_t>)>
void PlaneZnccCostLoop(benchmark::State& state) {
  const Images& im = TheImages();
  const mm::ZnccWindowsA windows = im.stats_a.Windows();
  std::vector<uint16_t> cost(im.view.total());
  const std::span<const float> view(im.view.ptr<float>(), im.view.total());
  for (auto _ : state) {
    Cost(windows, view, kMinVar, kScale, cost);
    benchmark::DoNotOptimize(cost.data());
  }
}

// The Highway pass (its target_used argument left at its default).
bool HighwayCost(const mm::ZnccWindowsA& a, std::span<const float> view, float min_var, int scale,
                 std::span<uint16_t> cost) {
  return mm::PlaneZnccCost(a, view, min_var, scale, cost);
}

void BM_PlaneZnccCostHighway(benchmark::State& state) { PlaneZnccCostLoop<HighwayCost>(state); }
BENCHMARK(BM_PlaneZnccCostHighway);

void BM_PlaneZnccCostScalar(benchmark::State& state) {
  PlaneZnccCostLoop<mm::PlaneZnccCostScalar>(state);
}
BENCHMARK(BM_PlaneZnccCostScalar);

// The peer: box filters and full-image arithmetic, scratch allocated once as the sweep did.
void BM_PlaneZnccCostOpenCvBoxFilters(benchmark::State& state) {
  const Images& im = TheImages();
  const cv::Mat& a = im.stats_a.a;
  const cv::Size size = a.size(), window(2 * kRadius + 1, 2 * kRadius + 1);
  cv::Mat ww(size, CV_32F), aw(size, CV_32F), mean_w(size, CV_32F), mean_ww(size, CV_32F);
  cv::Mat mean_aw(size, CV_32F), var_w(size, CV_32F), numerator(size, CV_32F);
  cv::Mat denominator(size, CV_32F), zncc(size, CV_32F), no_texture(size, CV_8U);
  cv::Mat cost(size, CV_16U);
  for (auto _ : state) {
    cv::multiply(im.view, im.view, ww);
    cv::multiply(a, im.view, aw);
    cv::boxFilter(im.view, mean_w, CV_32F, window, cv::Point(-1, -1), true, cv::BORDER_REFLECT);
    cv::boxFilter(ww, mean_ww, CV_32F, window, cv::Point(-1, -1), true, cv::BORDER_REFLECT);
    cv::boxFilter(aw, mean_aw, CV_32F, window, cv::Point(-1, -1), true, cv::BORDER_REFLECT);
    cv::multiply(mean_w, mean_w, var_w);
    cv::subtract(mean_ww, var_w, var_w);
    cv::multiply(im.stats_a.mean_a, mean_w, numerator);
    cv::subtract(mean_aw, numerator, numerator);
    cv::multiply(im.stats_a.var_a, var_w, denominator);
    cv::max(denominator, 1e-12, denominator);
    cv::sqrt(denominator, denominator);
    cv::divide(numerator, denominator, zncc);
    cv::compare(var_w, kMinVar, no_texture, cv::CMP_LT);
    zncc.setTo(0.0f, no_texture);
    zncc.convertTo(cost, CV_16U, -kScale, kScale);
    cv::min(cost, 2 * kScale, cost);
    benchmark::DoNotOptimize(cost.data);
  }
}
BENCHMARK(BM_PlaneZnccCostOpenCvBoxFilters);

// The warp the sweep runs before the cost at every plane (recon/plane_warp.h): the Highway
// pass, its scalar reference, and OpenCV's warpPerspective (its own SIMD) as the peer.
const Eigen::Matrix3d& WarpHomography() {
  static const Eigen::Matrix3d H =
      (Eigen::Matrix3d() << 1.01, 0.002, 2.5, -0.001, 1.0, 0.7, 1e-5, 2e-5, 1.0).finished();
  return H;
}

template <bool (*Warp)(std::span<const float>, int, int, const Eigen::Matrix3d&, std::span<float>)>
void PlaneWarpLoop(benchmark::State& state) {
  const Images& im = TheImages();
  std::vector<float> warped(im.view.total());
  const std::span<const float> view(im.view.ptr<float>(), im.view.total());
  for (auto _ : state) {
    Warp(view, im.view.cols, im.view.rows, WarpHomography(), warped);
    benchmark::DoNotOptimize(warped.data());
  }
}

// The Highway pass (its target_used argument left at its default).
bool HighwayWarp(std::span<const float> view, int width, int height, const Eigen::Matrix3d& H,
                 std::span<float> out) {
  return mm::WarpByHomography(view, width, height, H, out);
}

void BM_PlaneWarpHighway(benchmark::State& state) { PlaneWarpLoop<HighwayWarp>(state); }
BENCHMARK(BM_PlaneWarpHighway);

void BM_PlaneWarpScalar(benchmark::State& state) {
  PlaneWarpLoop<mm::WarpByHomographyScalar>(state);
}
BENCHMARK(BM_PlaneWarpScalar);

void BM_PlaneWarpOpenCv(benchmark::State& state) {
  const Images& im = TheImages();
  cv::Mat warped(im.view.size(), CV_32F), H;
  cv::eigen2cv(WarpHomography(), H);
  for (auto _ : state) {
    cv::warpPerspective(im.view, warped, H, im.view.size(), cv::INTER_LINEAR | cv::WARP_INVERSE_MAP,
                        cv::BORDER_REPLICATE);
    benchmark::DoNotOptimize(warped.data);
  }
}
BENCHMARK(BM_PlaneWarpOpenCv);

}  // namespace

BENCHMARK_MAIN();
