#include "base/checked_number.h"

#include <gtest/gtest.h>
#include <toml++/toml.h>

#include <limits>

namespace mm {
namespace {

TEST(CheckedNumber, IntegersOutsideTheRangeAreRejectedNotWrapped) {
  std::string problem;
  EXPECT_EQ(CheckedNumber<int>(int64_t{200}, {0, 1000000}, &problem), 200);
  // 4294967297 = 2^32 + 1: a cast to int gives 1.
  EXPECT_FALSE(CheckedNumber<int>(int64_t{4294967297}, {0, 1000000}, &problem));
  EXPECT_EQ(problem, "expected an integer in [0, 1000000], got 4294967297");
  EXPECT_FALSE(CheckedNumber<int>(int64_t{-1}, {0, 10}, &problem));
  EXPECT_FALSE(CheckedNumber<int>(std::numeric_limits<int64_t>::min(), {0, 10}, &problem));
}

TEST(CheckedNumber, IntegerFieldsTakeIntegralFloatsOnly) {
  std::string problem;
  EXPECT_EQ(CheckedNumber<int>(1e3, {0, 5000}, &problem), 1000);
  EXPECT_FALSE(CheckedNumber<int>(2.5, {0, 5000}, &problem));
  EXPECT_FALSE(CheckedNumber<int>(1e300, {0, 5000}, &problem));
  EXPECT_FALSE(CheckedNumber<int64_t>(1e300, {0, std::numeric_limits<int64_t>::max()}, &problem));
  EXPECT_FALSE(CheckedNumber<int>(std::numeric_limits<double>::infinity(), {0, 5}, &problem));
  EXPECT_FALSE(CheckedNumber<int>(std::nan(""), {0, 5}, &problem));
}

TEST(CheckedNumber, FloatingFieldsRejectNonFiniteAndAbsurdValues) {
  std::string problem;
  EXPECT_EQ(CheckedNumber<double>(int64_t{30}, {0.0, 3600.0}, &problem), 30.0);
  EXPECT_EQ(CheckedNumber<double>(2.5, {0.0, 3600.0}, &problem), 2.5);
  EXPECT_FALSE(CheckedNumber<double>(1e300, {0.0, 3600.0}, &problem));
  EXPECT_EQ(problem, "expected a finite number in [0, 3600], got 1e+300");
  EXPECT_FALSE(CheckedNumber<double>(std::numeric_limits<double>::infinity(), {0.0, 90.0},
                                     &problem));
  EXPECT_FALSE(CheckedNumber<double>(std::nan(""), {0.0, 90.0}, &problem));
  EXPECT_FALSE(CheckedNumber<double>(-0.5, {0.0, 90.0}, &problem));
}

TEST(CheckedNumber, ReadsTomlNodesAndRejectsOtherTypes) {
  const toml::table t = toml::parse("a = 7\nb = inf\nc = \"7\"\nd = true\ne = nan\n");
  std::string problem;
  EXPECT_EQ(CheckedNumberOf<int>(*t.get("a"), {0, 10}, &problem), 7);
  EXPECT_FALSE(CheckedNumberOf<double>(*t.get("b"), {0.0, 10.0}, &problem));
  EXPECT_FALSE(CheckedNumberOf<double>(*t.get("e"), {0.0, 10.0}, &problem));
  EXPECT_FALSE(CheckedNumberOf<int>(*t.get("c"), {0, 10}, &problem));
  EXPECT_EQ(problem.rfind("wrong type", 0), 0u) << problem;
  EXPECT_FALSE(CheckedNumberOf<int>(*t.get("d"), {0, 10}, &problem));
}

}  // namespace
}  // namespace mm
