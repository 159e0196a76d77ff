// The inline sine/cosine and atan2 of the kinematics agree with libm to a few ulp.
#include <cmath>
#include <random>

#include <gtest/gtest.h>

#include "kinematics/fast_trig.hpp"

namespace scaratwin::detail {
namespace {

TEST(FastTrig, SinCosMatchLibm) {
  std::mt19937_64 rng(99);
  std::uniform_real_distribution<double> d(-20.0, 20.0);
  double worst = 0.0;
  for (int i = 0; i < 1000000; ++i) {
    const double x = d(rng);
    double s, c;
    sincos_fast(x, s, c);
    worst = std::max({worst, std::abs(s - std::sin(x)), std::abs(c - std::cos(x))});
  }
  EXPECT_LE(worst, 4.5e-16);
  double s, c;
  sincos_fast(1e6, s, c);  // outside the fast range: libm
  EXPECT_EQ(s, std::sin(1e6));
  sincos_fast(NAN, s, c);
  EXPECT_TRUE(std::isnan(s) && std::isnan(c));
}

TEST(FastTrig, Atan2MatchesLibmInEveryQuadrant) {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> d(-1.0, 1.0);
  std::uniform_int_distribution<int> e(-30, 30);
  double worst = 0.0;
  for (int i = 0; i < 1000000; ++i) {
    const double y = std::ldexp(d(rng), e(rng)), x = std::ldexp(d(rng), e(rng));
    worst = std::max(worst, std::abs(atan2_fast(y, x) - std::atan2(y, x)));
  }
  EXPECT_LE(worst, 4.5e-16);
  for (double y : {0.0, -0.0, 1.0, -1.0}) {
    for (double x : {0.0, -0.0, 1.0, -1.0}) {
      EXPECT_EQ(atan2_fast(y, x), std::atan2(y, x)) << y << " " << x;
    }
  }
  EXPECT_EQ(atan2_fast(1.0, INFINITY), std::atan2(1.0, INFINITY));
}

}  // namespace
}  // namespace scaratwin::detail
