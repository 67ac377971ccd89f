#include <gtest/gtest.h>

#include <hwy/targets.h>
#include <iostream>
#include <random>

#include "recon/matcher.h"

namespace mm {
namespace {

// SIFT-like integer descriptors: B holds A's first `planted` rows with +-3 noise (true matches)
// plus unrelated rows; some exact duplicates create distance ties.
void MakeDescriptors(unsigned seed, int na, int nb, int planted, cv::Mat* a, cv::Mat* b) {
  std::mt19937 rng(seed);
  std::uniform_int_distribution<int> value(0, 60), jitter(-3, 3);
  *a = cv::Mat(na, 128, CV_32F);
  *b = cv::Mat(nb, 128, CV_32F);
  for (int r = 0; r < na; ++r) {
    for (int c = 0; c < 128; ++c) a->at<float>(r, c) = static_cast<float>(value(rng));
  }
  for (int r = 0; r < nb; ++r) {
    for (int c = 0; c < 128; ++c) {
      const float v = r < planted ? a->at<float>(r, c) + static_cast<float>(jitter(rng))
                                  : static_cast<float>(value(rng));
      b->at<float>(r, c) = std::max(0.0f, v);
    }
  }
  a->row(1).copyTo(a->row(2));  // Two identical rows of A: a tie for B's best.
  b->row(na + 1).copyTo(b->row(na + 2));
}

bool Same(const std::vector<Match>& x, const std::vector<Match>& y) {
  if (x.size() != y.size()) return false;
  for (size_t i = 0; i < x.size(); ++i) {
    if (x[i].index_a != y[i].index_a || x[i].index_b != y[i].index_b ||
        x[i].distance != y[i].distance) {
      return false;
    }
  }
  return true;
}

TEST(MatchDescriptors, EqualsScalarReferenceOnEveryCompiledTarget) {
  cv::Mat a, b;
  MakeDescriptors(1, 301, 347, 250, &a, &b);  // Odd sizes exercise the tile remainders.
  for (const double ratio : {0.8, 0.6}) {
    for (const bool mutual : {true, false}) {
      const MatchOptions options{ratio, mutual};
      const std::vector<Match> reference = MatchDescriptorsScalar(a, b, options);
      ASSERT_GT(reference.size(), 100u);
      int ran = 0;
      for (const int64_t target : hwy::SupportedAndGeneratedTargets()) {
        hwy::SetSupportedTargetsForTest(target);
        int64_t used = 0;
        const std::vector<Match> got = MatchDescriptors(a, b, options, &used);
        if (ratio == 0.8 && mutual) {
          std::cout << "Highway target " << hwy::TargetName(target) << " (ran "
                    << hwy::TargetName(used) << "): " << got.size() << " matches\n";
        }
        EXPECT_EQ(used, target) << hwy::TargetName(target);
        EXPECT_TRUE(Same(got, reference)) << hwy::TargetName(target) << " ratio " << ratio;
        ++ran;
      }
      hwy::SetSupportedTargetsForTest(0);
      EXPECT_GE(ran, 1);
    }
  }
}

// Descriptors of a few levels (0-2 in 8 dimensions, the rest equal) have many equal distances:
// every tie rule (the lowest index for the best, an equal second best, the mutual check) and
// every remainder of the kernel's blocks (A in fours, B in vectors of rows) against the
// scalar reference.
TEST(MatchDescriptors, TiesAndBlockRemaindersEqualTheScalarReferenceOnEveryTarget) {
  std::mt19937 rng(7);
  std::uniform_int_distribution<int> level(0, 2);
  for (const int rows : {2, 3, 5, 17, 33, 70}) {
    cv::Mat a(rows + 1, 128, CV_32F, cv::Scalar(9)), b(rows, 128, CV_32F, cv::Scalar(9));
    for (cv::Mat* m : {&a, &b}) {
      for (int r = 0; r < m->rows; ++r) {
        for (int c = 0; c < 8; ++c) m->at<float>(r, c) = static_cast<float>(level(rng));
      }
    }
    for (const bool mutual : {true, false}) {
      const MatchOptions options{1.0, mutual};  // Ratio 1: ties decide what is kept.
      const std::vector<Match> reference = MatchDescriptorsScalar(a, b, options);
      for (const int64_t target : hwy::SupportedAndGeneratedTargets()) {
        hwy::SetSupportedTargetsForTest(target);
        EXPECT_TRUE(Same(MatchDescriptors(a, b, options), reference))
            << hwy::TargetName(target) << ", " << rows << " rows, mutual " << mutual;
      }
      hwy::SetSupportedTargetsForTest(0);
    }
  }
}

TEST(MatchDescriptors, FindsPlantedMatchesAndAppliesTheRules) {
  cv::Mat a, b;
  MakeDescriptors(2, 200, 260, 150, &a, &b);
  const std::vector<Match> m = MatchDescriptors(a, b, {0.8, true});
  int correct = 0;
  for (const Match& x : m) correct += (x.index_a == x.index_b && x.index_a < 150) ? 1 : 0;
  // Rows 1 and 2 of A are identical: B's row 1 keeps A's row 1 (lowest index), so A's row 2
  // fails the mutual check; all other planted rows are found.
  EXPECT_EQ(correct, 149);
  EXPECT_EQ(static_cast<int>(m.size()), correct);
  // A stricter ratio keeps a subset; no mutual check keeps a superset.
  const std::vector<Match> strict = MatchDescriptors(a, b, {0.6, true});
  const std::vector<Match> loose = MatchDescriptors(a, b, {0.8, false});
  EXPECT_LE(strict.size(), m.size());
  EXPECT_GE(loose.size(), m.size());
}

TEST(MatchDescriptors, DegenerateInputs) {
  const cv::Mat one(1, 128, CV_32F, cv::Scalar(1));
  const cv::Mat empty;
  EXPECT_TRUE(MatchDescriptors(one, one, {}).empty());  // B needs two rows for the ratio.
  EXPECT_TRUE(MatchDescriptors(empty, one, {}).empty());
}

}  // namespace
}  // namespace mm
