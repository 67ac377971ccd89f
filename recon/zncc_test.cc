// The fused plane cost (recon/zncc.h): against a per-pixel ZNCC in double precision, and equal
// to its scalar reference on every Highway target compiled in.

#include <gtest/gtest.h>

#include <hwy/highway.h>
#include <hwy/targets.h>
#include <cmath>
#include <cstdint>
#include <iostream>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <random>
#include <vector>

#include "recon/zncc.h"

namespace mm {
namespace {

constexpr int kScale = 64;

// A random grey image with a flat (textureless) block, and a second one related to it by a
// brightness change plus noise, so that ZNCC spans most of its range.
struct Pair {
  cv::Mat view;
  ZnccStatsA stats_a;
  ZnccWindowsA windows;

  Pair(int width, int height, int radius, uint32_t seed) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> grey(0, 255), noise(-40, 40);
    cv::Mat a(height, width, CV_32F);
    view.create(height, width, CV_32F);
    for (int y = 0; y < height; ++y) {
      for (int x = 0; x < width; ++x) {
        const bool flat = x < width / 4 && y < height / 4;
        const float g = flat ? 100.0f : grey(rng);
        a.at<float>(y, x) = g;
        view.at<float>(y, x) = flat ? 90.0f : 0.8f * g + 20 + noise(rng);
      }
    }
    stats_a = ComputeZnccStatsA(a, radius);
    windows = stats_a.Windows();
  }
  const cv::Mat& A() const { return stats_a.a; }
  std::span<const float> View() const { return {view.ptr<float>(), view.total()}; }
};

int Reflect(int i, int n) { return i < 0 ? -i - 1 : (i >= n ? 2 * n - i - 1 : i); }

// ZNCC of the windows at (x, y), in double, straight from its definition.
double ZnccAt(const Pair& p, int x, int y, int radius, double* var_view) {
  double sa = 0, sw = 0, saa = 0, sww = 0, saw = 0;
  const int n = (2 * radius + 1) * (2 * radius + 1);
  for (int dy = -radius; dy <= radius; ++dy) {
    for (int dx = -radius; dx <= radius; ++dx) {
      const int yy = Reflect(y + dy, p.A().rows), xx = Reflect(x + dx, p.A().cols);
      const double av = p.A().at<float>(yy, xx), wv = p.view.at<float>(yy, xx);
      sa += av;
      sw += wv;
      saa += av * av;
      sww += wv * wv;
      saw += av * wv;
    }
  }
  const double ma = sa / n, mw = sw / n;
  const double va = saa / n - ma * ma;
  *var_view = sww / n - mw * mw;
  return (saw / n - ma * mw) / std::sqrt(std::max(va * *var_view, 1e-12));
}

TEST(PlaneZnccCost, IsOneMinusZnccInFixedPoint) {
  for (const int radius : {2, 3}) {
    const Pair p(53, 41, radius, 7);
    const float min_var = 1.0f;
    std::vector<uint16_t> cost(p.A().total());
    ASSERT_TRUE(PlaneZnccCostScalar(p.windows, p.View(), min_var, kScale, cost));
    int off_by_more_than_one = 0, textureless = 0;
    double lowest = 2, highest = 0;
    for (int y = 0; y < p.A().rows; ++y) {
      for (int x = 0; x < p.A().cols; ++x) {
        double var_view = 0;
        const double zncc = ZnccAt(p, x, y, radius, &var_view);
        const bool flat = var_view < min_var;
        textureless += flat;
        const double expected = flat ? kScale : std::clamp(kScale * (1 - zncc), 0.0, 2.0 * kScale);
        const int got = cost[static_cast<size_t>(y) * p.A().cols + x];
        off_by_more_than_one += std::abs(got - expected) > 1.0;
        lowest = std::min(lowest, 1 - zncc);
        highest = std::max(highest, 1 - zncc);
      }
    }
    std::cout << "radius " << radius << ": 1 - ZNCC in [" << lowest << ", " << highest << "], "
              << textureless << " textureless windows\n";
    EXPECT_EQ(off_by_more_than_one, 0);
    EXPECT_GT(textureless, 10);  // The flat block, and its reflection at the border.
    EXPECT_LT(lowest, 0.3);      // The view correlates with A...
    EXPECT_GT(highest, 0.6);     // ... through noise that spreads the costs.
  }
}

TEST(PlaneZnccCost, EqualsScalarReferenceOnEveryCompiledTarget) {
  for (const int width : {37, 320}) {  // 37: every vector width leaves a tail.
    const Pair p(width, 23, 3, 11);
    std::vector<uint16_t> reference(p.A().total());
    ASSERT_TRUE(PlaneZnccCostScalar(p.windows, p.View(), 1.0f, kScale, reference));
    int ran = 0;
    for (const int64_t target : hwy::SupportedAndGeneratedTargets()) {
      hwy::SetSupportedTargetsForTest(target);
      std::vector<uint16_t> cost(p.A().total(), 0xFFFF);
      int64_t used = 0;
      ASSERT_TRUE(PlaneZnccCost(p.windows, p.View(), 1.0f, kScale, cost, &used));
      if (width == 37) {
        std::cout << "Highway target " << hwy::TargetName(target) << " (ran "
                  << hwy::TargetName(used) << ")\n";
      }
      EXPECT_EQ(used, target);
      EXPECT_EQ(cost, reference) << hwy::TargetName(target) << ", width " << width;
      ++ran;
    }
    hwy::SetSupportedTargetsForTest(0);
    EXPECT_GE(ran, 1);
  }
}

TEST(PlaneZnccCost, RefusesSizesThatDoNotFit) {
  const Pair p(20, 12, 3, 1);
  std::vector<uint16_t> cost(p.A().total());
  std::vector<uint16_t> short_cost(p.A().total() - 1);
  EXPECT_FALSE(PlaneZnccCost(p.windows, p.View(), 1.0f, kScale, short_cost));
  ZnccWindowsA too_wide_window = p.windows;
  too_wide_window.radius = 6;  // 13 rows > 12.
  EXPECT_FALSE(PlaneZnccCost(too_wide_window, p.View(), 1.0f, kScale, cost));
  EXPECT_FALSE(PlaneZnccCostScalar(too_wide_window, p.View(), 1.0f, kScale, cost));
  EXPECT_TRUE(PlaneZnccCost(p.windows, p.View(), 1.0f, kScale, cost));
}

}  // namespace
}  // namespace mm
