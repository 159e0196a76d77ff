// The companion serial dialect of the firmware (setting 10), end to end: the real firmware in
// the emulator, its pty as the companion scripts' serialport, and the emulator's truth (the
// STEP/DIR pins, exact robot) as the oracle. The frame's zero is where each switch closed,
// computed here from the robot description's [endstops] by hand.
#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "robot_harness.hpp"

namespace scaratwin::test {
namespace {

// The paper's robot: Z switch at d1 = 0.1225 m x 205,560 steps/m, J2 at 117 deg x 945 steps/rad,
// J3 at -77 deg x 1,455 steps/rad as a joint count plus 0.8 x the J2 motor's count when J3
// homes (J2 backed off its switch by 40 steps).
const long kZeroZ = std::lround(0.1225 * 205560.0);
const long kZeroJ2 = std::lround(117.0 * M_PI / 180.0 * 945.0);
const long kZeroJ3 = std::lround(-77.0 * M_PI / 180.0 * 1455.0) +
                     static_cast<long>(std::floor(0.8 * static_cast<double>(kZeroJ2 - 40)));

// Waits until the truth shows every motor at rest at (z, j2, j3).
bool reaches(Robot& r, long z, long j2, long j3) {
  for (int i = 0; i < 2000; ++i) {
    const Truth t = r.truth();
    if (t.i("z") == z && t.i("j2") == j2 && t.i("j3") == j3) return true;
    r.line(0.005);
  }
  return false;
}

class CompanionSerial : public ::testing::Test {
 protected:
  void SetUp() override {
    ASSERT_TRUE(robot.ok()) << robot.error();
    ASSERT_EQ(robot.request("SR=0=\n").value_or(""), "AK=SR=0=");
    ASSERT_EQ(robot.request("CF=10=1=\n").value_or(""), "AK=CF=1=");
    ASSERT_TRUE(robot.home());
  }
  Robot robot;
};

TEST_F(CompanionSerial, TargetsInTheSwitchFrameMoveAllThreeMotorsTogether) {
  EXPECT_EQ(kZeroZ, 25181);  // the description's numbers, as docs/firmware.md gives them
  EXPECT_EQ(kZeroJ2, 1930);
  EXPECT_EQ(kZeroJ3, -443);
  const Truth before = robot.truth();
  // as the companion scripts' numberTran: three targets, then m; no replies
  robot.send("z-6000\ny-2400\nx1500.6\n");
  EXPECT_FALSE(robot.line(0.3)) << "an accepted target is not answered";
  EXPECT_EQ(robot.truth().u("steps_z"), before.u("steps_z")) << "a target alone moves nothing";
  // m, then at once a v1 query and the next companion targets: the query is answered while the
  // motors run; the companion lines wait for the move to end, as the sketch reads nothing then
  robot.send("m\nQS=\nz-5000\nm\n");
  auto during = robot.wait_for("ST=");
  ASSERT_TRUE(during);
  auto moving = parse_report(*during);
  ASSERT_TRUE(moving);
  EXPECT_EQ(moving->flags() & 2, 2) << "v1 is served during the move: " << *during;
  ASSERT_TRUE(reaches(robot, kZeroZ - 5000, kZeroJ2 - 2400, kZeroJ3 + 1501));
  robot.send("QS=\n");
  auto st = robot.wait_for("ST=");
  ASSERT_TRUE(st);
  auto rep = parse_report(*st);
  ASSERT_TRUE(rep);
  EXPECT_EQ(rep->z(), kZeroZ - 5000) << "the firmware's own count agrees with the truth";
  // an m with unchanged targets does not move
  const Truth at = robot.truth();
  robot.send("m\nPI=3=\n");
  EXPECT_EQ(robot.wait_for("AK=PI=").value_or(""), "AK=PI=3=");
  EXPECT_EQ(robot.truth().u("steps_j2"), at.u("steps_j2"));
}

TEST_F(CompanionSerial, RefusedTargetsAnswerAnErrorAndMoveNothing) {
  const Truth before = robot.truth();
  // Z: 2,056..24,667 counts is -23,125..-514 in the switch frame
  robot.send("z-30000\n");
  EXPECT_EQ(robot.line().value_or(""), "error: z-30000 beyond the limits -23125..-514");
  robot.send("z-400\n");
  EXPECT_EQ(robot.line().value_or(""), "error: z-400 beyond the limits -23125..-514");
  // after homing the J2 target is where J2 stands: count 0, so J3's range is its joint limits
  // -1904..5205 (no coupling share) minus the zero -443
  robot.send("x7200\n");
  EXPECT_EQ(robot.line().value_or(""), "error: x7200 beyond the limits -1461..5648");
  robot.send("y1abc\nq12\nmx\n");
  EXPECT_EQ(robot.line().value_or(""), "error: y1abc is not a whole number of steps");
  EXPECT_EQ(robot.line().value_or(""), "error: q12 unknown (z, y, x or m)");
  EXPECT_EQ(robot.line().value_or(""), "error: mx unknown (z, y, x or m)");
  // a J2 target accepted after a J3 target can carry J3 out: x-1400 is inside with J2 at count
  // 30 (share 24) but not at count 1800 (share 1440: -1904 + 1440 + 443 = -21): m refuses it
  // and moves nothing
  robot.send("y-1900\nx-1400\ny-130\nm\n");
  EXPECT_EQ(robot.line().value_or(""), "error: m: x-1400 beyond the limits -21..7088");
  robot.send("PI=1=\n");
  EXPECT_EQ(robot.wait_for("AK=PI=").value_or(""), "AK=PI=1=");
  const Truth after = robot.truth();
  for (const char* k : {"steps_z", "steps_j2", "steps_j3"}) {
    EXPECT_EQ(after.u(k), before.u(k)) << k << ": a refused target moved a motor";
  }
}

// A host that overruns the receive buffer while an m move keeps the companion lines waiting
// (the 128-byte ring fills behind the waiting line): each lost line is answered ER=6=0= in its
// place (docs/protocol.md section 8), the waiting line is carried out, and the line after the
// loss starts afresh, in either dialect.
TEST_F(CompanionSerial, ALineLostWhileAMoveRunsIsAnsweredInItsPlace) {
  const long j3 = robot.truth().i("j3");
  // the firmware counts up to 255 lost lines in a row (serial.cpp): 200 lines, of which the
  // ring keeps about 12 while the move runs
  constexpr int kLines = 200;
  std::string burst = "y-2400\nm\nz-5000\n";  // z waits until the J2 move has ended
  for (int k = 0; k < kLines; ++k) burst += "PI=" + std::to_string(1000 + k) + "=\n";
  robot.send(burst);  // 2,000 bytes at once
  std::vector<std::string> replies;
  while (static_cast<int>(replies.size()) < kLines) {
    auto l = robot.line(20.0);
    ASSERT_TRUE(l) << "only " << replies.size() << " replies to " << kLines << " lines";
    replies.push_back(*l);
  }
  int lost = 0;
  for (int k = 0; k < kLines; ++k) {
    const std::string& r = replies[static_cast<std::size_t>(k)];
    if (r == "ER=6=0=") {
      ++lost;
    } else {
      EXPECT_EQ(r, "AK=PI=" + std::to_string(1000 + k) + "=") << "reply " << k;
    }
  }
  EXPECT_GT(lost, 0) << "the burst did not overrun the buffer: the test proves nothing";
  // the line after the loss is read from its start: a companion line, then a v1 line
  robot.send("z-4000\nm\nPI=7=\n");
  EXPECT_EQ(robot.line().value_or(""), "AK=PI=7=") << "no extra reply, no error line";
  EXPECT_TRUE(reaches(robot, kZeroZ - 4000, kZeroJ2 - 2400, j3));
}

// Setting 10 = 2: the periodic reports as a single-class sketch sends them, one value per
// line (t, z, y, x, w, g), the counts in the switch frame; the truth (the STEP/DIR pins) is
// the oracle for the counts. A QS is still answered with ST, and setting 1 brings ST back.
TEST_F(CompanionSerial, SingleClassReportsOneValuePerLineInTheSwitchFrame) {
  robot.send("z-6000\ny-2400\nx1500\nm\n");
  ASSERT_TRUE(reaches(robot, kZeroZ - 6000, kZeroJ2 - 2400, kZeroJ3 + 1500));
  const Truth at = robot.truth();
  ASSERT_EQ(robot.request("CF=10=2=\n").value_or(""), "AK=CF=2=");
  ASSERT_EQ(robot.request("SR=100=\n").value_or(""), "AK=SR=100=");
  std::vector<std::string> lines;
  for (int i = 0; i < 40; ++i) {
    auto l = robot.line(10.0, true);
    ASSERT_TRUE(l) << "no line after " << i;
    lines.push_back(*l);
  }
  std::size_t first = 0;
  while (first < lines.size() && lines[first][0] != 't') ++first;
  ASSERT_LT(first + 18, lines.size());
  const std::string order = "tzyxwg";
  std::vector<long long> t_us;
  for (std::size_t k = first; k + 6 <= lines.size(); k += 6) {
    for (std::size_t i = 0; i < 6; ++i) {
      ASSERT_EQ(lines[k + i][0], order[i]) << "line " << k + i << ": " << lines[k + i];
      EXPECT_EQ(lines[k + i].find_first_not_of("-0123456789", 1), std::string::npos)
          << lines[k + i];
    }
    t_us.push_back(std::stoll(lines[k].substr(1)));
    EXPECT_EQ(std::stol(lines[k + 1].substr(1)), at.i("z") - kZeroZ);
    EXPECT_EQ(std::stol(lines[k + 2].substr(1)), at.i("j2") - kZeroJ2);
    EXPECT_EQ(std::stol(lines[k + 3].substr(1)), at.i("j3") - kZeroJ3);
    EXPECT_EQ(std::stol(lines[k + 3].substr(1)), 1500);
  }
  // 100 Hz: a sample every 10 ms of the robot's clock, on the report grid (an AVR at rest
  // sleeps between its 1 ms clock ticks, so a sample is taken up to a tick late)
  ASSERT_GE(t_us.size(), 3u);
  for (std::size_t k = 1; k < t_us.size(); ++k) {
    EXPECT_NEAR(static_cast<double>(t_us[k] - t_us[k - 1]), 10000.0, 1100.0);
  }
  EXPECT_NEAR(
      static_cast<double>(t_us.back() - t_us.front()) / static_cast<double>(t_us.size() - 1),
      10000.0, 400.0);
  auto st = robot.query_state();
  ASSERT_TRUE(st) << "QS is answered with ST in the single-class form too";
  EXPECT_EQ(st->z(), at.i("z"));
  // the reply, after any one-value report lines already on their way (they are not v1 lines)
  robot.send("CF=10=1=\n");
  std::optional<std::string> reply;
  for (int i = 0; i < 100; ++i) {
    reply = robot.line();
    if (!reply || reply->size() < 2 || order.find((*reply)[0]) == std::string::npos ||
        reply->find_first_not_of("-0123456789", 1) != std::string::npos) {
      break;
    }
  }
  ASSERT_EQ(reply.value_or(""), "AK=CF=1=");
  auto l = robot.wait_for("ST=");
  ASSERT_TRUE(l) << "setting 1: the periodic reports are ST again";
}

TEST(CompanionSerialOff, CompanionLinesAreVersionOneErrorsAndViceVersa) {
  Robot r;
  ASSERT_TRUE(r.ok()) << r.error();
  ASSERT_EQ(r.request("SR=0=\n").value_or(""), "AK=SR=0=");
  // off (the default): a companion line is a v1 line with a bad character in its code (at 0)
  EXPECT_EQ(r.request("z100\n").value_or(""), "ER=2=0=");
  EXPECT_EQ(r.request("CF=10=\n").value_or(""), "AK=CF=0=");
  // on: a v1 line is still v1, never a companion target
  ASSERT_EQ(r.request("CF=10=1=\n").value_or(""), "AK=CF=1=");
  EXPECT_EQ(r.request("PI=5=\n").value_or(""), "AK=PI=5=");
  EXPECT_EQ(r.request("Z100\n").value_or(""), "ER=2=1=");
  // m before homing
  r.send("m\n");
  EXPECT_EQ(r.line().value_or(""), "error: m not homed");
}

}  // namespace
}  // namespace scaratwin::test
