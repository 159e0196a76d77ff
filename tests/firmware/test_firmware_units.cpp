// Host-built unit tests of the firmware's pure modules (compiled with g++ from firmware/src):
// the step distribution (DDA), the motion buffer and its limit checks, the jog ramps, the
// settings block and the servo conversion. Property tests use fixed seeds.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <random>
#include <vector>

#include "motion.h"
#include "ramp.h"
#include "segment.h"
#include "servo_math.h"
#include "settings.h"

namespace fw {
namespace {

Segment make_segment(int16_t dz, int16_t dj2, int16_t dj3, uint16_t dt_ms) {
  Segment s{};
  s.delta[0] = dz;
  s.delta[1] = dj2;
  s.delta[2] = dj3;
  s.length_q8 = static_cast<uint32_t>(dt_ms) * kTicksPerMs * 256u;
  return s;
}

TEST(Dda, EmitsExactlyTheStepsOfEverySegmentWhateverTheRateProfile) {
  std::mt19937 rng(1234);
  for (int trial = 0; trial < 2000; ++trial) {
    const uint16_t dt_ms = static_cast<uint16_t>(1 + rng() % 300);
    const int max_d = dt_ms * kTicksPerMs;  // at most one step per tick
    auto rnd_delta = [&] {
      return static_cast<int16_t>(static_cast<int>(rng() % (2 * max_d + 1)) - max_d);
    };
    const Segment s = make_segment(rnd_delta(), rnd_delta(), rnd_delta(), dt_ms);
    Dda dda;
    dda.start(s);
    int steps[3] = {0, 0, 0};
    const bool ramped = trial % 2 == 1;  // half the trials slow down and speed up (hold)
    uint32_t ticks = 0;
    while (!dda.done()) {
      uint16_t rate = 256;
      if (ramped) rate = static_cast<uint16_t>(1 + (ticks * 7) % 256);
      const uint8_t m = dda.tick(rate);
      for (int i = 0; i < 3; ++i) steps[i] += (m >> i) & 1;
      ++ticks;
      ASSERT_LT(ticks, 10'000'000u);
    }
    for (int i = 0; i < 3; ++i) {
      EXPECT_EQ(steps[i], std::abs(s.delta[i])) << "trial " << trial << " axis " << i;
      EXPECT_EQ(((dda.dir_negative >> i) & 1) != 0, s.delta[i] < 0);
    }
    if (!ramped) {
      EXPECT_EQ(ticks, static_cast<uint32_t>(dt_ms) * kTicksPerMs);
    }
  }
}

TEST(Dda, SpacesStepsEvenlyAtConstantRate) {
  const Segment s = make_segment(37, 0, -200, 100);  // 2000 ticks
  Dda dda;
  dda.start(s);
  std::vector<uint32_t> at;
  for (uint32_t t = 0; !dda.done(); ++t)
    if (dda.tick(256) & 1) at.push_back(t);
  ASSERT_EQ(at.size(), 37u);
  uint32_t lo = UINT32_MAX, hi = 0;
  for (std::size_t k = 1; k < at.size(); ++k) {
    lo = std::min(lo, at[k] - at[k - 1]);
    hi = std::max(hi, at[k] - at[k - 1]);
  }
  EXPECT_LE(hi - lo, 1u);
}

MotorLimits limits() {
  MotorLimits l;
  for (int i = 0; i < 3; ++i) {
    l.max_speed[i] = kDefaultMaxSpeed;
    l.max_accel[i] = kDefaultMaxAccel;
  }
  return l;
}

TEST(Motion, AcceptsASmoothTrajectoryWithinTheLimitsAndEndsOnIt) {
  PlanState st{{0, 0, 0}, {0, 0, 0}};
  // quintic over 4 s, 60 samples, 1500 steps on J2: peak 703 steps/s, 563 steps/s^2
  const int n = 60;
  int32_t sum = 0;
  for (int k = 1; k <= n; ++k) {
    const double tau = static_cast<double>(k) / n;
    const double s = 10 * std::pow(tau, 3) - 15 * std::pow(tau, 4) + 6 * std::pow(tau, 5);
    TimedPoint p{};
    p.seq = static_cast<uint16_t>(k - 1);
    p.dt_ms = 67;
    p.target[1] = static_cast<int32_t>(std::lround(1500 * s));
    p.grip_cdeg = -1;
    p.last = k == n;
    Segment seg{};
    uint8_t axis = 9;
    ASSERT_EQ(plan_point(limits(), st, p, seg, &axis), kPlanOk) << "point " << k;
    sum += seg.delta[1];
    EXPECT_EQ(seg.flags & kSegLast, k == n ? kSegLast : 0);
  }
  EXPECT_EQ(sum, 1500);
  EXPECT_EQ(st.position[1], 1500);
}

TEST(Motion, RefusesPointsBeyondTheSpeedOrAccelerationLimitAndNamesTheAxis) {
  PlanState st{{0, 0, 0}, {0, 0, 0}};
  Segment seg{};
  uint8_t axis = 9;
  TimedPoint fast{0, 100, {0, 0, 600}, 0, -1, false};  // 6000 steps/s on J3
  EXPECT_EQ(plan_point(limits(), st, fast, seg, &axis), kPlanSpeed);
  EXPECT_EQ(axis, 2);
  TimedPoint jump{0, 100, {0, 100, 0}, 0, -1, false};  // 0 -> 1000 steps/s in 0.1 s
  EXPECT_EQ(plan_point(limits(), st, jump, seg, &axis), kPlanAccel);
  EXPECT_EQ(axis, 1);
  TimedPoint gentle{0, 100, {10, 0, 0}, 0, -1, false};  // 100 steps/s
  EXPECT_EQ(plan_point(limits(), st, gentle, seg, &axis), kPlanOk);
  TimedPoint abrupt_end{1, 100, {40, 0, 0}, 0, -1, true};  // ends at 300 steps/s
  EXPECT_EQ(plan_point(limits(), st, abrupt_end, seg, &axis), kPlanAccel);
  TimedPoint zero_dt{1, 0, {10, 0, 0}, 0, -1, false};
  EXPECT_EQ(plan_point(limits(), st, zero_dt, seg, &axis), kPlanBadDuration);
  EXPECT_EQ(st.position[0], 10) << "refused points leave the plan unchanged";
}

TEST(Motion, QueueIsFifoWithOneSlotReserved) {
  MotionQueue q;
  EXPECT_EQ(q.free_slots(), kQueueSize - 1);
  for (int k = 0; k < kQueueSize - 1; ++k) {
    Segment s{};
    s.seq = static_cast<uint16_t>(k);
    ASSERT_TRUE(q.push(s));
  }
  EXPECT_FALSE(q.push(Segment{}));
  EXPECT_EQ(q.free_slots(), 0);
  for (int k = 0; k < 3; ++k) {
    ASSERT_NE(q.front(), nullptr);
    EXPECT_EQ(q.front()->seq, k);
    q.pop();
  }
  EXPECT_EQ(q.free_slots(), 3);
  q.clear();
  EXPECT_TRUE(q.empty());
  EXPECT_EQ(q.front(), nullptr);
}

TEST(Motion, HoldDecelerationMatchesTheAccelerationLimit) {
  // 50 steps in 100 ms = 500 steps/s; at 1500 steps/s^2 the hold takes 1/3 s = 6667 ticks
  const uint16_t dec = hold_decrement_q16(50, 100, 1500);
  EXPECT_GE(65536.0 / dec, 6667.0) << "never harder than the limit";
  EXPECT_LE(65536.0 / dec, 6667.0 * 1.15);
  EXPECT_EQ(hold_decrement_q16(0, 100, 1500), 65535);
}

TEST(Ramp, PositionMovesEndExactlyWithinSpeedAndAcceleration) {
  std::mt19937 rng(99);
  for (int trial = 0; trial < 300; ++trial) {
    const int32_t dist = static_cast<int32_t>(rng() % 20001) - 10000;
    const float vmax = 200.0f + static_cast<float>(rng() % 4800);
    const float accel = 500.0f + static_cast<float>(rng() % 3000);
    AxisRamp r;
    r.move_by(dist);
    int32_t sum = 0;
    int prev_d = 0;
    int n = 0;
    // what the motor sees: steps per 10 ms interval; their change is the acceleration, which
    // may exceed accel * dt^2 only by the rounding of the three positions (0.5 + 1 + 0.5)
    const double max_dd = accel * 0.01 * 0.01 + 2.0;
    while (!r.idle()) {
      const int16_t d = r.next(0.01f, vmax, accel);
      sum += d;
      EXPECT_LE(std::abs(d), static_cast<int>(vmax * 0.01f) + 1);
      EXPECT_LE(std::abs(d - prev_d), max_dd) << "trial " << trial << " interval " << n;
      prev_d = d;
      ASSERT_LT(++n, 100000);
    }
    EXPECT_LE(std::abs(prev_d), max_dd) << "the last interval ends at rest";
    EXPECT_EQ(sum, dist) << "trial " << trial;
  }
}

TEST(Ramp, VelocityModeRunsAtSpeedAndStopsAtTheLimit) {
  AxisRamp r;
  r.run_at(-1000.0f);
  int32_t sum = 0;
  for (int k = 0; k < 200; ++k) sum += r.next(0.01f, 5000.0f, 1500.0f);
  EXPECT_FLOAT_EQ(r.speed(), -1000.0f);
  r.run_at(0.0f);
  int k = 0;
  while (!r.idle() && k < 1000) {
    sum += r.next(0.01f, 5000.0f, 1500.0f);
    ++k;
  }
  EXPECT_TRUE(r.idle());
  EXPECT_NEAR(k, 67, 2) << "1000 steps/s at 1500 steps/s^2 stops in 0.67 s";
  EXPECT_LT(sum, -1000);
}

// A hard stop forgets the motion: no speed, no steps owed, and the next move starts from rest
// (at 1500 steps/s^2 the first 10 ms interval reaches 15 steps/s: 0.15 step, none emitted).
TEST(Ramp, ResetForgetsAllMotion) {
  AxisRamp r;
  r.move_by(5000);
  int32_t sum = 0;
  for (int k = 0; k < 100; ++k) sum += r.next(0.01f, 5000.0f, 1500.0f);
  ASSERT_FLOAT_EQ(r.speed(), 1500.0f) << "1 s at 1500 steps/s^2";
  // 15 steps/s more each interval: 0.01 x 15 x (1 + 2 + ... + 100) = 757.5 steps
  ASSERT_NEAR(sum, 757.5, 1.0);
  r.reset();
  EXPECT_TRUE(r.idle());
  EXPECT_EQ(r.mode(), AxisRamp::kIdle);
  EXPECT_EQ(r.speed(), 0.0f);
  EXPECT_EQ(r.next(0.01f, 5000.0f, 1500.0f), 0) << "idle emits nothing";
  r.move_by(100);
  EXPECT_EQ(r.next(0.01f, 5000.0f, 1500.0f), 0);
  EXPECT_FLOAT_EQ(r.speed(), 15.0f);
  sum = 0;
  int n = 1;
  while (!r.idle() && n < 10000) {
    sum += r.next(0.01f, 5000.0f, 1500.0f);
    ++n;
  }
  EXPECT_EQ(sum, 100) << "the whole move, none of the 4242 steps left of the one before";
  // the same after a velocity run
  r.run_at(-800.0f);
  for (int k = 0; k < 10; ++k) r.next(0.01f, 5000.0f, 1500.0f);
  EXPECT_FLOAT_EQ(r.speed(), -150.0f);
  r.reset();
  EXPECT_TRUE(r.idle());
  EXPECT_EQ(r.speed(), 0.0f);
}

TEST(Settings, DefaultsAreValidAndCorruptionIsDetected) {
  Settings s;
  settings_defaults(s);
  EXPECT_TRUE(settings_valid(s));
  auto* bytes = reinterpret_cast<uint8_t*>(&s);
  for (std::size_t i = 0; i < offsetof(Settings, checksum); ++i) {
    Settings c = s;
    reinterpret_cast<uint8_t*>(&c)[i] ^= 0x5a;
    EXPECT_FALSE(settings_valid(c)) << "byte " << i;
  }
  Settings blank;
  std::memset(&blank, 0xff, sizeof blank);  // erased EEPROM
  EXPECT_FALSE(settings_valid(blank));
  s.version = kSettingsVersion + 1;
  settings_seal(s);
  EXPECT_FALSE(settings_valid(s)) << "another layout version";
  (void)bytes;
}

TEST(Settings, KeysHaveRangesAndUnknownKeysAreRefused) {
  Settings s;
  settings_defaults(s);
  int32_t v = 0;
  ASSERT_EQ(settings_get(s, 1, &v), kSettingOk);
  EXPECT_EQ(v, 5000);
  EXPECT_EQ(settings_set(s, 3, 250), kSettingOk);
  EXPECT_EQ(s.report_hz, 250);
  EXPECT_TRUE(settings_valid(s)) << "set reseals";
  EXPECT_EQ(settings_set(s, 3, 1001), kSettingBadValue);
  EXPECT_EQ(settings_set(s, 1, 0), kSettingBadValue);
  EXPECT_EQ(settings_set(s, 1, static_cast<int32_t>(kTickHz)), kSettingBadValue)
      << "the step generator emits at most one step per two ticks";
  EXPECT_EQ(settings_get(s, 0, &v), kSettingUnknownKey);
  EXPECT_EQ(s.companion, 0) << "the companion dialect is off by default";
  EXPECT_EQ(settings_set(s, 10, 1), kSettingOk);
  EXPECT_EQ(s.companion, 1);
  EXPECT_EQ(settings_set(s, 10, 2), kSettingOk) << "2: and the single-class reports";
  EXPECT_EQ(s.companion, 2);
  EXPECT_EQ(settings_set(s, 10, 3), kSettingBadValue);
  EXPECT_EQ(s.companion, 2) << "a refused value changes nothing";
  // key 11, the serial rate: only the rates the 16 MHz clock makes within 1 %
  EXPECT_EQ(s.baud_hundreds, 1152) << "115200 baud by default";
  for (int32_t h : {96, 576, 1152, 2500, 5000, 10000})
    EXPECT_EQ(settings_set(s, 11, h), kSettingOk);
  for (int32_t h : {0, 95, 192, 384, 2304, 4608, 10001, 20000}) {
    EXPECT_EQ(settings_set(s, 11, h), kSettingBadValue) << h;
  }
  EXPECT_EQ(s.baud_hundreds, 10000) << "a refused value changes nothing";
  EXPECT_EQ(settings_set(s, 12, 1), kSettingUnknownKey);
}

TEST(Servo, PulseAndAngleConvertBothWays) {
  EXPECT_EQ(servo_cdeg_to_halfus(0, 544, 2400), 1088);
  EXPECT_EQ(servo_cdeg_to_halfus(18000, 544, 2400), 4800);
  EXPECT_EQ(servo_cdeg_to_halfus(-5, 544, 2400), 1088) << "clamped";
  for (int32_t c = 0; c <= 18000; c += 7) {
    const uint16_t p = servo_cdeg_to_halfus(c, 544, 2400);
    EXPECT_LE(std::abs(servo_halfus_to_cdeg(p, 544, 2400) - c), 3) << c;  // 0.5 us = 4.8 cdeg
  }
}

}  // namespace
}  // namespace fw
