// The companion serial dialect's pure part (firmware/src/companion.cpp): parsing, the limits in
// the companion frame, and the error lines, written out by hand.
#include <gtest/gtest.h>

#include <cstring>
#include <string>

#include "companion.h"

namespace fw {
namespace {

CompanionKind parse(const char* line, uint8_t* axis, int32_t* steps) {
  return companion_parse(line, static_cast<uint8_t>(std::strlen(line)), axis, steps);
}

TEST(Companion, ParsesTargetsAndTheMove) {
  uint8_t axis = 9;
  int32_t steps = 0;
  ASSERT_EQ(parse("z13000", &axis, &steps), kCompanionTarget);
  EXPECT_EQ(axis, 0);
  EXPECT_EQ(steps, 13000);
  ASSERT_EQ(parse("y-1900", &axis, &steps), kCompanionTarget);
  EXPECT_EQ(axis, 1);
  EXPECT_EQ(steps, -1900);
  ASSERT_EQ(parse("x3419.6", &axis, &steps), kCompanionTarget);  // MATLAB's num2str
  EXPECT_EQ(axis, 2);
  EXPECT_EQ(steps, 3420);
  ASSERT_EQ(parse("x-3419.5", &axis, &steps), kCompanionTarget);
  EXPECT_EQ(steps, -3420);
  ASSERT_EQ(parse("x-3419.49", &axis, &steps), kCompanionTarget);
  EXPECT_EQ(steps, -3419);
  ASSERT_EQ(parse("z999999999", &axis, &steps), kCompanionTarget);
  EXPECT_EQ(steps, 999999999);
  EXPECT_EQ(parse("m", &axis, &steps), kCompanionMove);
}

TEST(Companion, RefusesWhatIsNotATargetOrTheMove) {
  uint8_t axis = 0;
  int32_t steps = 0;
  for (const char* bad :
       {"z", "z-", "z1.", "z.5", "z1e3", "z 12", "z12 ", "z+12", "z1000000000", "z1-2", "x1.2.3"}) {
    EXPECT_EQ(parse(bad, &axis, &steps), kCompanionBadLine) << bad;
  }
  for (const char* unknown : {"a", "g", "mm", "m1", "q100", ""}) {
    EXPECT_EQ(parse(unknown, &axis, &steps), kCompanionUnknown) << unknown;
  }
}

TEST(Companion, RangesAreTheLimitsInTheSwitchFrameJ3MovingWithJ2) {
  // the paper's robot homed: switches at Z 25181, J2 1930, J3 -1955 + floor(0.8 * 1890)
  const int32_t zero[3] = {25181, 1930, -1955 + 1512};
  int32_t lo = 0, hi = 0;
  companion_range(zero, 0, 800, 0, &lo, &hi);
  EXPECT_EQ(lo, kLimitMin[0] - 25181);
  EXPECT_EQ(hi, kLimitMax[0] - 25181);
  companion_range(zero, 0, 800, 1, &lo, &hi);
  EXPECT_EQ(lo, kLimitMin[1] - 1930);
  EXPECT_EQ(hi, kLimitMax[1] - 1930);
  // J2 target -1930 puts the J2 motor at count 0: no coupling share
  companion_range(zero, -1930, 800, 2, &lo, &hi);
  EXPECT_EQ(lo, kLimitMin[2] - zero[2]);
  EXPECT_EQ(hi, kLimitMax[2] - zero[2]);
  // J2 motor at -1001: floor(0.8 * -1001) = -801
  companion_range(zero, -1930 - 1001, 800, 2, &lo, &hi);
  EXPECT_EQ(lo, kLimitMin[2] - 801 - zero[2]);
  EXPECT_EQ(hi, kLimitMax[2] - 801 - zero[2]);
}

TEST(Companion, ErrorLinesNameTheLineAndTheReason) {
  char out[64];
  auto line = [&](const char* l, CompanionError why, int32_t lo, int32_t hi) {
    const uint8_t n =
        companion_error_line(out, sizeof out, l, static_cast<uint8_t>(std::strlen(l)), why, lo, hi);
    return std::string(out, n);
  };
  EXPECT_EQ(line("z-30000", kCompErrLimit, -23125, -514),
            "error: z-30000 beyond the limits -23125..-514\n");
  EXPECT_EQ(line("y1a", kCompErrBadNumber, 0, 0), "error: y1a is not a whole number of steps\n");
  EXPECT_EQ(line("g", kCompErrUnknown, 0, 0), "error: g unknown (z, y, x or m)\n");
  EXPECT_EQ(line("m", kCompErrNotHomed, 0, 0), "error: m not homed\n");
  EXPECT_EQ(line("m", kCompErrBusy, 0, 0), "error: m busy\n");
  EXPECT_EQ(line("m", kCompErrHalted, 0, 0), "error: m halted (send ~)\n");
  EXPECT_EQ(line("x-2147483648", kCompErrLimit, -2147483647 - 1, 2147483647),
            "error: x-2147483648 beyond the limits -2147483648..2147483647\n");
  const uint8_t m =
      companion_error_line(out, sizeof out, "m", 1, kCompErrLimit, -21, 7088, 2, -1400);
  EXPECT_EQ(std::string(out, m), "error: m: x-1400 beyond the limits -21..7088\n");
  // a short buffer keeps the newline
  const uint8_t n = companion_error_line(out, 10, "z-30000", 7, kCompErrLimit, 1, 2);
  EXPECT_EQ(std::string(out, n), "error: z-\n");
}

// The single-class report (setting 10 = 2): one line per value, fixed order, the counts in the
// switch frame; written out by hand.
TEST(Companion, SingleClassReportIsOneValuePerLine) {
  char buf[kCompanionReportMax];
  const int32_t pos[kNumAxes] = {24667, 0, 0};
  const int32_t zero[kNumAxes] = {25181, 1930, -443};
  uint8_t n = companion_report_lines(buf, sizeof buf, 4294967295u, pos, zero, 9000, 7500);
  EXPECT_EQ(std::string(buf, n), "t4294967295\nz-514\ny-1930\nx443\nw9000\ng7500\n");
  n = companion_report_lines(buf, sizeof buf, 0, zero, zero, 0, 0);
  EXPECT_EQ(std::string(buf, n), "t0\nz0\ny0\nx0\nw0\ng0\n");
  // the extremes of an int32 count (sign and ten digits) and 10^k boundaries
  const int32_t far[kNumAxes] = {-2147483647 - 1, 2147483647, 1000000000};
  const int32_t none[kNumAxes] = {0, 0, 0};
  n = companion_report_lines(buf, sizeof buf, 1000000, far, none, 10, 99);
  EXPECT_EQ(std::string(buf, n), "t1000000\nz-2147483648\ny2147483647\nx1000000000\nw10\ng99\n");
  // what does not fit is not written at all
  EXPECT_EQ(companion_report_lines(buf, 20, 4294967295u, pos, zero, 9000, 7500), 0);
  EXPECT_EQ(companion_report_lines(buf, 41, 4294967295u, pos, zero, 9000, 7500), 0);
  EXPECT_EQ(companion_report_lines(buf, 42, 4294967295u, pos, zero, 9000, 7500), 42);
}

}  // namespace
}  // namespace fw
