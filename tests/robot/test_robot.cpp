// End-to-end tests of the physical-robot layer: the real firmware ELF runs in the emulator,
// and the tests talk to it through the pty exactly as the hub talks to a board, checking the
// firmware's replies against the truth the emulator counts on the STEP/DIR pins. Functional
// tests run unpaced (--speed 0); every time they check is the emulated time (the firmware's
// t_us or the emulator's sim_us), so the result does not depend on the machine's speed.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "robot_harness.hpp"
#include "scaratwin/vision/webcam.hpp"
#include "trajectory_points.hpp"

namespace scaratwin::test {
namespace {

// Jogs J2 from count 0 by `steps` and waits until the count is there and the motor stopped.
void jog_j2_from_zero(Robot& r, int steps) {
  ASSERT_EQ(r.request("JG=1=" + std::to_string(steps) + "=\n").value_or(""), "AK=JG=");
  for (int i = 0; i < 400; ++i) {
    auto st = r.query_state();
    ASSERT_TRUE(st);
    if (st->j2() == steps && (st->flags() & 2) == 0) return;
  }
  FAIL() << "J2 did not come to rest at " << steps;
}

class RobotTest : public ::testing::Test {
 protected:
  void SetUp() override { ASSERT_TRUE(robot.ok()) << robot.error(); }
  Robot robot;
};

TEST_F(RobotTest, SaysHelloWithVersion) {
  EXPECT_EQ(robot.request("HI=1=\n").value_or(""), "HI=1=scara-uno=0.1.0=");
  EXPECT_EQ(robot.request("HI=2=\n").value_or(""), "ER=13=1=");  // unsupported version
  EXPECT_EQ(robot.request("PI=7=\n").value_or(""), "AK=PI=7=");
}

TEST_F(RobotTest, HomingFindsTheSwitchesAndEndsAtTheHomePose) {
  ASSERT_TRUE(robot.home());
  const Truth t = robot.truth();
  EXPECT_EQ(t.i("z"), 24667);
  EXPECT_EQ(t.i("j2"), 0);
  EXPECT_EQ(t.i("j3"), 0);
  auto st = robot.query_state();
  ASSERT_TRUE(st);
  EXPECT_EQ(st->z(), 24667);
  EXPECT_EQ(st->j2(), 0);
  EXPECT_EQ(st->j3(), 0);
  EXPECT_EQ(st->flags() & 1, 1) << "homed flag";
}

TEST_F(RobotTest, TrajectoryEndsAtThePlannedStepsWithAllJointsTogether) {
  ASSERT_TRUE(robot.home());
  const auto pts = plan_points({0.10, 0.8, -0.6, 0.5}, 5.0);
  ASSERT_EQ(pts.size(), 59u);
  // Together: the quintic moves every joint along the same normalised profile, so at any
  // instant each axis must have covered the same fraction of its travel, within the whole-step
  // quantisation of each axis. Sample the truth while loading and until the trajectory is done.
  const std::array<double, 3> from{24667, 0, 0};
  std::array<double, 3> travel{};
  for (int i = 0; i < 3; ++i) travel[i] = pts.back().steps[i] - from[i];
  double worst = 0, allowed = 0.002;
  for (double t : travel) allowed += 1.0 / std::fabs(t);
  int samples_moving = 0;
  auto last_sample = std::chrono::steady_clock::now();
  auto sample = [&](bool always) {
    const auto now = std::chrono::steady_clock::now();
    if (!always && now - last_sample < std::chrono::milliseconds(20)) return;
    last_sample = now;
    const Truth t = robot.truth();
    const std::array<double, 3> pos{static_cast<double>(t.i("z")), static_cast<double>(t.i("j2")),
                                    static_cast<double>(t.i("j3"))};
    std::array<double, 3> frac{};
    for (int i = 0; i < 3; ++i) frac[i] = (pos[i] - from[i]) / travel[i];
    const double spread =
        *std::max_element(frac.begin(), frac.end()) - *std::min_element(frac.begin(), frac.end());
    worst = std::max(worst, spread);
    if (frac[0] > 0.05 && frac[0] < 0.95) ++samples_moving;
  };
  ASSERT_TRUE(load_trajectory(robot, pts, nullptr, [&] { sample(false); }));
  std::optional<std::string> done;
  while (!done) {
    sample(true);
    done = robot.line(0.01);
    if (done && done->rfind("EV=3=", 0) != 0) done.reset();
  }
  EXPECT_EQ(*done, "EV=3=59=");
  EXPECT_LE(worst, allowed) << "the axes drifted apart";
  EXPECT_GT(samples_moving, 5) << "too few samples during the motion to judge";
  const Truth t = robot.truth();
  EXPECT_EQ(t.i("z"), pts.back().steps[0]);
  EXPECT_EQ(t.i("j2"), pts.back().steps[1]);
  EXPECT_EQ(t.i("j3"), pts.back().steps[2]);
  auto st = robot.query_state();
  ASSERT_TRUE(st);
  EXPECT_EQ(st->z(), pts.back().steps[0]);
  EXPECT_EQ(st->j2(), pts.back().steps[1]);
  EXPECT_EQ(st->j3(), pts.back().steps[2]);
}

TEST_F(RobotTest, JogButtonsMoveTheMotorsAndTheReportsShowIt) {
  const Truth before = robot.truth();
  ASSERT_EQ(robot.side("press j2+ 400"), "OK press j2+ 400");
  auto ev = robot.wait_for("EV=4=", 10.0);
  ASSERT_TRUE(ev);
  EXPECT_EQ(*ev, "EV=4=2=");  // button 2 = J2+
  // wait until the motion has ended (released, ramped down)
  for (int i = 0; i < 200; ++i) {
    auto st = robot.query_state();
    ASSERT_TRUE(st);
    if ((st->flags() & 2) == 0 && st->j2() > 0) break;
  }
  const Truth after = robot.truth();
  EXPECT_GT(after.i("j2") - before.i("j2"), 100) << "J2 moved while the button was held";
  EXPECT_EQ(after.i("z"), before.i("z"));
  auto st = robot.query_state();
  ASSERT_TRUE(st);
  EXPECT_EQ(st->j2(), after.i("j2")) << "the report shows the true J2 position";
  ASSERT_EQ(robot.side("press z- 300"), "OK press z- 300");
  ASSERT_TRUE(robot.wait_for("EV=4=1=", 10.0));
}

TEST_F(RobotTest, StopHaltsMotionWithinTenMilliseconds) {
  ASSERT_EQ(robot.request("JG=1=3000=\n").value_or(""), "AK=JG=");
  // wait until J2 runs at speed
  const auto t0 = std::chrono::steady_clock::now();
  while (robot.truth().i("j2") < 800 &&
         std::chrono::steady_clock::now() - t0 < std::chrono::seconds(30)) {
  }
  ASSERT_GE(robot.truth().i("j2"), 800);
  robot.send("!");
  ASSERT_TRUE(robot.wait_for("EV=6=", 10.0));
  const Truth t = robot.truth();
  const auto stop_rx = t.u("last_rx_sim_us");
  const auto last_step = t.u("last_step_sim_us");
  EXPECT_LT(t.i("j2"), 3000) << "stopped before the end of the jog";
  EXPECT_LE(last_step, stop_rx + 10000)
      << "last step " << last_step - stop_rx << " us after the stop byte";
  auto st = robot.query_state();
  ASSERT_TRUE(st);
  EXPECT_EQ(st->j2(), t.i("j2"));
  EXPECT_EQ(st->flags() & 16, 16) << "halted flag";
  EXPECT_EQ(robot.request("JG=1=10=\n").value_or(""), "ER=14=") << "motion refused when halted";
  robot.send("~");
  EXPECT_TRUE(robot.wait_for("EV=8=", 10.0));
  EXPECT_EQ(robot.request("JG=1=10=\n").value_or(""), "AK=JG=");
}

TEST_F(RobotTest, EveryMalformedPacketGetsAnErrorAndTheFirmwareKeepsWorking) {
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"XX=\n", "ER=3="},                          // unknown code
      {"SR=1=2=\n", "ER=4=2="},                    // too many fields
      {"TP=1=\n", "ER=4=1="},                      // too few fields
      {"SR=abc=\n", "ER=5=0="},                    // not a number (field 0)
      {"SR=99999999999=\n", "ER=5=0="},            // out of i32 range
      {"SR=5000=\n", "ER=11=0="},                  // rate out of range
      {"sr=1=\n", "ER=2=0="},                      // lower-case code (byte 0)
      {"SR=1\n", "ER=2=4="},                       // no delimiter after the last field (byte 4)
      {"SR==\n", "ER=5=0="},                       // empty field (field 0)
      {"JG=7=10=\n", "ER=11=0="},                  // no axis 7
      {"CF=99=\n", "ER=11=0="},                    // unknown setting
      {"TP=0=100=1=2=3=4=\n", "ER=10=0="},         // TP without TB
      {"TB=1=\n", "ER=7="},                        // not homed
      {std::string(120, 'A') + "\n", "ER=1=96="},  // line too long
      {"\x01\x02=\n", "ER=2=0="},                  // control characters (byte 0)
  };
  for (const auto& [bad, want] : cases) {
    auto reply = robot.request(bad);
    ASSERT_TRUE(reply) << "no reply to " << bad;
    EXPECT_EQ(*reply, want) << "reply to '" << bad << "'";
    EXPECT_EQ(robot.request("PI=1=\n").value_or(""), "AK=PI=1=") << "after " << bad;
  }
  // bytes corrupted on the line (emulator fault injection) also get an error reply
  ASSERT_EQ(robot.side("corrupt 2 rx"), "OK corrupt 2 rx");
  // ('P' ^ 0x55 and 'I' ^ 0x55 are control characters: the first bad byte is byte 0)
  EXPECT_EQ(robot.request("PI=5=\n").value_or("timeout"), "ER=2=0=");
  EXPECT_EQ(robot.request("PI=6=\n").value_or(""), "AK=PI=6=");
}

TEST_F(RobotTest, SixHundredPointsStreamThroughFlowControlWithoutOverflow) {
  ASSERT_TRUE(robot.home());
  // a slow sine on J2 and Z, 20 ms per point: 12 s of motion, far more than the queue holds
  std::vector<Point> pts;
  for (int k = 1; k <= 600; ++k) {
    const double s = std::sin(2.0 * M_PI * k / 600.0);
    const double s2 = std::sin(M_PI * k / 600.0);
    pts.push_back({20,
                   {24667 - static_cast<std::int32_t>(std::lround(2000 * s2 * s2)),
                    static_cast<std::int32_t>(std::lround(300 * s * s2)), 0},
                   0});
  }
  int acks = 0;
  ASSERT_TRUE(load_trajectory(robot, pts, &acks));
  EXPECT_EQ(acks, 600);
  std::vector<std::string> skipped;
  auto done = robot.wait_for("EV=3=", 60.0, &skipped);
  ASSERT_TRUE(done);
  EXPECT_EQ(*done, "EV=3=600=");
  for (const auto& l : skipped) EXPECT_NE(l.rfind("ER=", 0), 0u) << l;
  const Truth t = robot.truth();
  EXPECT_EQ(t.i("z"), pts.back().steps[0]);
  EXPECT_EQ(t.i("j2"), pts.back().steps[1]);
}

TEST_F(RobotTest, FaultsLostStepsAndACutLinkAreVisible) {
  ASSERT_EQ(robot.side("lose j2 5"), "OK lose j2 5");
  ASSERT_NO_FATAL_FAILURE(jog_j2_from_zero(robot, 200));
  EXPECT_EQ(robot.truth().i("j2"), 195) << "the slipping belt lost 5 of 200 steps";
  // cut the link for 5 s of emulated time; everything is judged in emulated time, since the
  // unpaced emulator runs several times faster than the wall clock
  const auto before_us = robot.truth().u("sim_us");
  ASSERT_EQ(robot.side("cut 5000"), "OK cut 5000");
  const auto after_us = robot.truth().u("sim_us");  // the cut began in [before, after]
  robot.send("PI=9=\n");
  const auto sent_us = robot.truth().u("sim_us");  // the bytes entered at or before this
  ASSERT_LT(sent_us, before_us + 5000000) << "machine too slow to send within the cut";
  std::vector<std::string> during;
  while (robot.truth().u("sim_us") < after_us + 5200000) {
    while (auto l = robot.line(0.01)) during.push_back(*l);
  }
  for (const auto& l : during) EXPECT_NE(l, "AK=PI=9=") << "a reply came through the cut";
  EXPECT_EQ(robot.request("PI=10=\n", 20.0).value_or(""), "AK=PI=10=") << "link back";
}

// Sends TB=n= and the first `count` points of `pts`, each after the previous one's AK (the
// queue holds 15, so up to 15 points go without waiting for credit); then the host falls
// silent, as a hub that gave up, was killed or lost its link does.
void load_and_abandon(Robot& r, const std::vector<Point>& pts, int count) {
  ASSERT_EQ(r.request("TB=" + std::to_string(pts.size()) + "=\n").value_or(""), "AK=TB=15=");
  for (int k = 0; k < count; ++k) {
    auto ak = r.request(tp(k, pts[static_cast<std::size_t>(k)]));
    ASSERT_TRUE(ak && ak->rfind("AK=TP=", 0) == 0) << "point " << k << ": " << ak.value_or("");
  }
}

// A host that gives up on a trajectory (a cut link, a killed or interrupted hub) must never
// lock the robot. The firmware runs the points it has and stops by itself when they run out
// (EV 5, at rest at the last point it got); then TB, HM and JG each take over from the
// abandoned trajectory (issue 17: all three were refused as busy until '!' or SP).
TEST_F(RobotTest, AnAbandonedTrajectoryStopsByItselfAndNeverLocksTheRobot) {
  ASSERT_TRUE(robot.home());
  const auto pts = plan_points({0.10, 0.8, -0.6, 0.5}, 5.0);
  ASSERT_GE(pts.size(), 30u);
  // the link is cut right after 15 points (the queue is full, so they run): the robot
  // stops at point 14 on its own, its underrun event lost in the cut
  ASSERT_NO_FATAL_FAILURE(load_and_abandon(robot, pts, 15));
  const auto cut_from = robot.truth().u("sim_us");
  ASSERT_EQ(robot.side("cut 3000"), "OK cut 3000");
  while (robot.truth().u("sim_us") < cut_from + 3200000) {
    while (robot.line(0.01)) {
    }
  }
  ASSERT_NO_FATAL_FAILURE(expect_at_rest_at(robot, pts[14].steps));
  auto st = robot.query_state();
  ASSERT_TRUE(st);
  EXPECT_EQ(st->flags() & 4, 4) << "the trajectory waits for its next point";
  // a new trajectory replaces it (TB clears the queue)
  EXPECT_EQ(robot.request("TB=2=\n").value_or(""), "AK=TB=15=");
  // that one is abandoned too, before any point: homing takes over from it
  EXPECT_EQ(robot.request("HM=\n").value_or(""), "AK=HM=");
  ASSERT_TRUE(robot.wait_for("EV=1=", 60.0));
  // abandoned once more, this time with an underrun the host hears of; a jog takes over
  ASSERT_NO_FATAL_FAILURE(load_and_abandon(robot, pts, 15));
  EXPECT_EQ(robot.wait_for("EV=5=", 20.0).value_or(""), "EV=5=15=");
  ASSERT_NO_FATAL_FAILURE(expect_at_rest_at(robot, pts[14].steps));
  EXPECT_EQ(robot.request("JG=1=100=\n").value_or(""), "AK=JG=");
  for (int i = 0; i < 400; ++i) {
    auto r = robot.query_state();
    ASSERT_TRUE(r);
    if (r->j2() == pts[14].steps[1] + 100 && (r->flags() & 2) == 0) break;
  }
  EXPECT_EQ(robot.truth().i("j2"), pts[14].steps[1] + 100) << "the jog ran";
  // and a whole trajectory runs after homing again
  ASSERT_TRUE(robot.home());
  ASSERT_TRUE(load_trajectory(robot, pts));
  EXPECT_EQ(robot.wait_for("EV=3=", 60.0).value_or(""), "EV=3=" + std::to_string(pts.size()) + "=");
  ASSERT_NO_FATAL_FAILURE(expect_at_rest_at(robot, pts.back().steps));
}

// HM recovers from a hold ('#') too: the held trajectory is dropped and the robot homes
// (it was refused with 14 until '~' or '!').
TEST_F(RobotTest, HomingRecoversFromAHeldTrajectory) {
  ASSERT_TRUE(robot.home());
  const auto pts = plan_points({0.10, 0.8, -0.6, 0.5}, 5.0);
  ASSERT_TRUE(load_trajectory(robot, pts));
  robot.send("#");
  ASSERT_TRUE(robot.wait_for("EV=7=", 20.0));
  EXPECT_EQ(robot.request("HM=\n").value_or(""), "AK=HM=");
  ASSERT_TRUE(robot.wait_for("EV=1=", 60.0));
  ASSERT_NO_FATAL_FAILURE(expect_at_rest_at(robot, {24667, 0, 0}));
  auto st = robot.query_state();
  ASSERT_TRUE(st);
  EXPECT_EQ(st->flags() & (4 | 8 | 16), 0) << "no trajectory, hold or halt left";
  ASSERT_TRUE(load_trajectory(robot, pts));
  EXPECT_TRUE(robot.wait_for("EV=3=", 60.0));
}

// Homing from a pose where J3 is already past its switch (as after J2 homed from some poses,
// the belt coupling turning J3 with it): the firmware runs it off the switch, then homes.
TEST(RobotStart, HomingStartsFromBeyondASwitch) {
  Robot robot({"--speed", "0", "--start-steps", "24667", "0", "-2600"});  // J3 switch: -1955
  ASSERT_TRUE(robot.ok()) << robot.error();
  ASSERT_TRUE(robot.home(60.0)) << "homing failed";
  const Truth t = robot.truth();
  EXPECT_EQ(t.i("z"), 24667);
  EXPECT_EQ(t.i("j2"), 0);
  EXPECT_EQ(t.i("j3"), 0);
}

// The robot has no encoders: lost steps do not show in its counts. Homing again does show
// them: each switch closes where the motor really is, and the firmware reports how far the
// count was from it (EV 10/11/12 for Z/J2/J3) before EV 1.
TEST_F(RobotTest, HomingAgainReportsTheStepsTheMotorsLost) {
  ASSERT_TRUE(robot.home());
  ASSERT_EQ(robot.side("lose j2 40"), "OK lose j2 40");
  ASSERT_NO_FATAL_FAILURE(jog_j2_from_zero(robot, 400));
  EXPECT_EQ(robot.truth().i("j2"), 360) << "the motor made 360 of 400 steps";
  ASSERT_EQ(robot.request("HM=\n").value_or(""), "AK=HM=");
  std::vector<std::string> events;
  for (;;) {
    auto l = robot.line(60.0);
    ASSERT_TRUE(l) << "no EV=1= after homing again";
    if (l->rfind("EV=", 0) == 0) events.push_back(*l);
    if (*l == "EV=1=") break;
  }
  EXPECT_EQ(events, (std::vector<std::string>{"EV=10=0=", "EV=11=40=", "EV=12=0=", "EV=1="}));
  // the counts are right again
  auto st = robot.query_state();
  ASSERT_TRUE(st);
  EXPECT_EQ(st->j2(), robot.truth().i("j2"));
}

// Paced to real time, so that the host reads the reports as a hub would (3 s).
TEST(RobotPaced, ReportsCarryConsecutiveSequenceNumbersAtTheConfiguredRate) {
  Robot robot({"--speed", "1"});
  ASSERT_TRUE(robot.ok()) << robot.error();
  ASSERT_EQ(robot.request("SR=200=\n").value_or(""), "AK=SR=200=");
  std::vector<Report> reps;
  while (reps.size() < 600) {
    auto l = robot.line(10.0, true);
    ASSERT_TRUE(l);
    if (auto r = parse_report(*l)) reps.push_back(*r);
  }
  for (std::size_t k = 1; k < reps.size(); ++k) {
    ASSERT_EQ((reps[k].seq() - reps[k - 1].seq() + 65536) % 65536, 1) << "gap at " << k;
  }
  const double span_s = static_cast<std::uint32_t>(reps.back().t_us() - reps.front().t_us()) / 1e6;
  EXPECT_NEAR(static_cast<double>(reps.size() - 1) / span_s, 200.0, 1.0);
}

// The printed calibration pattern: the operator lays it on the physical table through the
// side channel, and the webcam sees its tags (at its full 1280x960) until it is taken away.
TEST(RobotAsBuilt, ThePatternLiesOnTheTableOnRequest) {
  Robot r({"--speed", "0", "--plant", "as-built", "--as-built-seed", "11"});
  ASSERT_TRUE(r.ok()) << r.error();
  std::vector<std::uint8_t> rgb;
  ASSERT_EQ(r.grab(1280, 960, rgb).rfind("FRAME ", 0), 0u);
  ASSERT_EQ(rgb.size(), 1280u * 960u * 3u);
  EXPECT_TRUE(detect_tags(RgbImage{1280, 960, rgb}).empty());
  EXPECT_EQ(r.side("pattern on"), "OK pattern on");
  ASSERT_EQ(r.grab(1280, 960, rgb).rfind("FRAME ", 0), 0u);
  const auto tags = detect_tags(RgbImage{1280, 960, rgb});
  // the arm at home lies over the pattern's row nearest the x axis and hides some of it
  EXPECT_GE(tags.size(), 12u);
  for (const auto& t : tags) EXPECT_LT(t.id, 20);
  EXPECT_EQ(r.side("pattern maybe"),
            "ERR pattern needs on (lay the printed pattern on the table) or off");
  EXPECT_EQ(r.side("pattern off"), "OK pattern off");
  ASSERT_EQ(r.grab(1280, 960, rgb).rfind("FRAME ", 0), 0u);
  EXPECT_TRUE(detect_tags(RgbImage{1280, 960, rgb}).empty());
  EXPECT_EQ(r.grab(1282, 960, rgb), "ERR grab needs a size from 16x16 to 1280x960");
}

TEST_F(RobotTest, TheIdealRobotHasNoPatternToLay) {
  EXPECT_EQ(robot.side("pattern on").rfind("ERR the ideal robot has no physical world", 0), 0u);
}

}  // namespace
}  // namespace scaratwin::test
