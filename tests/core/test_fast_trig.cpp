// The inline sine/cosine and atan2 of the kinematics agree with libm to a few ulp, and their
// two-lane forms with the scalar ones exactly.
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

TEST(FastTrig, TwoLaneFormsMatchTheScalarOnesBitForBit) {
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> d(-20.0, 20.0);
  std::uniform_int_distribution<int> e(-30, 30);
  for (int i = 0; i < 200000; ++i) {
    const V2d x{d(rng), d(rng)};
    V2d s, c;
    sincos_fast(x, s, c);
    for (int l = 0; l < 2; ++l) {
      double sl, cl;
      sincos_fast(x[l], sl, cl);
      ASSERT_EQ(s[l], sl) << x[l];
      ASSERT_EQ(c[l], cl) << x[l];
    }
    const V2d y0{std::ldexp(d(rng), e(rng)), std::ldexp(d(rng), e(rng))};
    const V2d x0{std::ldexp(d(rng), e(rng)), std::ldexp(d(rng), e(rng))};
    const V2d y1{d(rng), d(rng)}, x1{d(rng), d(rng)};
    V2d r0, r1;
    atan2_fast(y0, x0, y1, x1, r0, r1);
    const V2d r2 = atan2_fast(y0, x0);
    for (int l = 0; l < 2; ++l) {
      ASSERT_EQ(r0[l], atan2_fast(y0[l], x0[l])) << y0[l] << " " << x0[l];
      ASSERT_EQ(r2[l], r0[l]);
      ASSERT_EQ(r1[l], atan2_fast(y1[l], x1[l])) << y1[l] << " " << x1[l];
    }
  }
  // a lane outside the polynomial's domain sends both to the fallback.
  double s0, c0;
  sincos_fast(0.5, s0, c0);
  V2d s, c;
  sincos_fast(V2d{0.5, NAN}, s, c);
  EXPECT_EQ(s[0], s0);
  EXPECT_TRUE(std::isnan(s[1]) && std::isnan(c[1]));
  const V2d z = atan2_fast(V2d{0.0, -0.0}, V2d{-0.0, -1.0});
  EXPECT_EQ(z[0], std::atan2(0.0, -0.0));
  EXPECT_EQ(z[1], std::atan2(-0.0, -1.0));
  EXPECT_TRUE(std::signbit(z[1]));
}

}  // namespace
}  // namespace scaratwin::detail
