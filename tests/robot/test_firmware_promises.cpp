// The firmware's promises of docs/protocol.md (sections 6, 8, 9) and docs/firmware.md, one test
// each, end to end: the real firmware ELF in the emulator, driven through its pty as the hub
// drives a board, judged by the exact codes and events the documents give and by the truth
// the emulator counts on the pins. Times are emulated time (the firmware's t_us, the
// emulator's sim_us), never the wall clock.
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "robot_harness.hpp"
#include "trajectory_points.hpp"

namespace scaratwin::test {
namespace {

constexpr std::int32_t kHomeZ = 24667;    // counts of the home pose (d1 = 0.12 m)
constexpr std::int32_t kZSwitch = 25181;  // the Z switch closes here (docs/firmware.md)
constexpr int kFlagHomed = 1, kFlagMoving = 2, kFlagTrajectory = 4, kFlagHold = 8, kFlagHalted = 16;

class Promise : public ::testing::Test {
 protected:
  void SetUp() override { ASSERT_TRUE(robot.ok()) << robot.error(); }
  Robot robot;
};

// Lines until emulated time has run `ms` past now (the side channel's sim_us), all kept.
std::vector<std::string> lines_for_sim_ms(Robot& r, double ms) {
  std::vector<std::string> out;
  const auto until = r.truth().u("sim_us") + static_cast<std::uint64_t>(ms * 1000.0);
  while (r.truth().u("sim_us") < until) {
    while (auto l = r.line(0.005, true)) out.push_back(*l);
  }
  return out;
}

// Starts a jog of J2 and returns once it runs at speed.
void jog_j2_to_speed(Robot& r) {
  ASSERT_EQ(r.request("JG=1=3000=\n").value_or(""), "AK=JG=");
  for (int i = 0; i < 20000 && r.truth().i("j2") < 800; ++i) {
  }
  ASSERT_GE(r.truth().i("j2"), 800) << "the jog did not start";
}

// SP= is the stop of the packet stream: the same hard stop as '!' (protocol.md section 8).
TEST_F(Promise, StopPacketHaltsWithinTenMillisecondsAndRefusesMotionUntilHomed) {
  ASSERT_NO_FATAL_FAILURE(jog_j2_to_speed(robot));
  EXPECT_EQ(robot.request("SP=\n").value_or(""), "AK=SP=");
  EXPECT_EQ(robot.wait_for("EV=", 10.0).value_or(""), "EV=6=");
  const Truth t = robot.truth();
  EXPECT_LT(t.i("j2"), 3000) << "stopped before the end of the jog";
  // the '\n' that completed SP= is the last byte the firmware received
  EXPECT_LE(t.u("last_step_sim_us"), t.u("last_rx_sim_us") + 10000)
      << "last step " << t.u("last_step_sim_us") - t.u("last_rx_sim_us") << " us after SP=";
  auto st = robot.query_state();
  ASSERT_TRUE(st);
  EXPECT_EQ(st->j2(), t.i("j2"));
  EXPECT_EQ(st->flags() & (kFlagHalted | kFlagMoving), kFlagHalted);
  EXPECT_EQ(robot.request("JG=1=10=\n").value_or(""), "ER=14=");
  EXPECT_EQ(robot.request("TB=2=\n").value_or(""), "ER=14=");
  // nothing moved on the refusals
  lines_for_sim_ms(robot, 50);
  EXPECT_EQ(robot.truth().i("j2"), t.i("j2"));
  // HM clears the halt
  ASSERT_TRUE(robot.home());
  st = robot.query_state();
  ASSERT_TRUE(st);
  EXPECT_EQ(st->flags() & (kFlagHalted | kFlagHomed), kFlagHomed);
}

// '#' holds a running trajectory: it decelerates (no hard stop), keeps its queue, sends EV=7=
// at rest and refuses motion with 14; '~' resumes it (EV=8=) and it ends at its planned steps.
TEST_F(Promise, FeedHoldDeceleratesKeepsTheQueueAndResumeFinishesTheTrajectory) {
  ASSERT_TRUE(robot.home());
  // 15 points: all of them fit the queue, so the whole trajectory is loaded before it starts
  // and the hold can come at its fastest part
  const auto pts = plan_points({0.10, 0.8, -0.6, 0.5}, 5.0, 16);
  ASSERT_EQ(pts.size(), 15u);
  ASSERT_TRUE(load_trajectory(robot, pts));
  const double z_travel = pts.back().steps[0] - kHomeZ;
  auto z_done = [&](const Truth& t) { return static_cast<double>(t.i("z") - kHomeZ) / z_travel; };
  for (int i = 0; i < 100000; ++i) {
    if (z_done(robot.truth()) >= 0.4) break;
  }
  robot.send("#");
  std::vector<std::string> before_held;
  ASSERT_TRUE(robot.wait_for("EV=7=", 20.0, &before_held)) << "no EV=7= after '#'";
  for (const auto& l : before_held) EXPECT_NE(l.rfind("EV=", 0), 0u) << l;
  const Truth held = robot.truth();
  const double done = z_done(held);
  EXPECT_GT(done, 0.4);
  EXPECT_LT(done, 0.9) << "held well before the end";
  // at about 1,500 steps/s of Z there, a deceleration at 1,500 steps/s^2 takes about a second;
  // a hard stop would end within one 50 us tick
  EXPECT_GT(held.u("last_step_sim_us"), held.u("last_rx_sim_us") + 300000)
      << "the hold stopped at once instead of decelerating";
  auto st = robot.query_state();
  ASSERT_TRUE(st);
  EXPECT_EQ(st->flags() & (kFlagHold | kFlagTrajectory | kFlagHalted), kFlagHold | kFlagTrajectory);
  EXPECT_GT(st->queue_free(), 0);
  EXPECT_LT(st->queue_free(), 15) << "the queue is kept";
  EXPECT_EQ(robot.request("TB=2=\n").value_or(""), "ER=14=");
  EXPECT_EQ(robot.request("JG=1=10=\n").value_or(""), "ER=14=");
  // held: nothing moves for half a second of emulated time
  for (const auto& l : lines_for_sim_ms(robot, 500)) EXPECT_NE(l.rfind("EV=", 0), 0u) << l;
  EXPECT_EQ(robot.truth().i("j2"), held.i("j2"));
  EXPECT_EQ(robot.truth().i("z"), held.i("z"));
  robot.send("~");
  EXPECT_EQ(robot.wait_for("EV=", 10.0).value_or(""), "EV=8=");
  EXPECT_EQ(robot.wait_for("EV=", 60.0).value_or(""), "EV=3=15=");
  ASSERT_NO_FATAL_FAILURE(expect_at_rest_at(robot, pts.back().steps));
}

// After homing the switches are guarded: one that closes during a motion stops everything,
// sends EV=2=<axis>=, clears the homed flag and halts (docs/firmware.md, Motion).
TEST_F(Promise, EndstopGuardStopsAMotionThatClosesASwitch) {
  ASSERT_TRUE(robot.home());
  ASSERT_EQ(robot.request("JG=0=2000=\n").value_or(""), "AK=JG=");  // up, past the Z switch
  EXPECT_EQ(robot.wait_for("EV=", 20.0).value_or(""), "EV=2=0=");
  lines_for_sim_ms(robot, 50);
  const Truth t = robot.truth();
  // the generator stops on the tick after the step that closed the switch
  EXPECT_GE(t.i("z"), kZSwitch);
  EXPECT_LE(t.i("z"), kZSwitch + 1);
  EXPECT_EQ(t.i("j2"), 0);
  auto st = robot.query_state();
  ASSERT_TRUE(st);
  EXPECT_EQ(st->z(), t.i("z"));
  EXPECT_EQ(st->flags() & (kFlagHomed | kFlagHalted | kFlagMoving), kFlagHalted);
  EXPECT_EQ(st->flags() & 32, 32) << "Z switch closed";
  EXPECT_EQ(robot.request("JG=0=-100=\n").value_or(""), "ER=14=");
}

// A switch that never closes (a broken wire): the search gives up after 60,000 steps with
// EV=9=<axis>= and halts (docs/firmware.md, Homing). Z homes first; J2's switch is broken.
TEST_F(Promise, HomingFailsWithTheAxisWhenItsSwitchNeverCloses) {
  ASSERT_EQ(robot.side("endstop j2 open"), "OK endstop j2 open");
  ASSERT_EQ(robot.request("CF=6=5000=\n").value_or(""), "AK=CF=5000=");  // a faster search
  const std::int64_t j2_from = robot.truth().i("j2");
  ASSERT_EQ(robot.request("HM=\n").value_or(""), "AK=HM=");
  EXPECT_EQ(robot.wait_for("EV=", 120.0).value_or(""), "EV=9=1=");
  lines_for_sim_ms(robot, 50);
  const Truth t = robot.truth();
  EXPECT_GT(t.i("j2") - j2_from, 60000) << "searched the whole 60,000 steps";
  EXPECT_LE(t.i("j2") - j2_from, 60100) << "and stopped there";
  EXPECT_EQ(t.i("z"), kZSwitch - 40) << "Z homed (backed off its switch by 40 steps)";
  auto st = robot.query_state();
  ASSERT_TRUE(st);
  EXPECT_EQ(st->flags() & (kFlagHomed | kFlagHalted | kFlagMoving), kFlagHalted);
  EXPECT_EQ(robot.request("TB=2=\n").value_or(""), "ER=14=");
}

// A queue that runs dry before the last point: the robot holds the last point it got, sends
// EV=5=<next seq>= once, and goes on when the next point comes (protocol.md section 9, step 4).
TEST_F(Promise, AQueueUnderrunHoldsTheLastPointAndTheTrajectoryGoesOnWhenPointsCome) {
  ASSERT_TRUE(robot.home());
  const auto pts = plan_points({0.10, 0.8, -0.6, 0.5}, 5.0);
  ASSERT_EQ(pts.size(), 59u);
  const auto tb = robot.request("TB=59=\n");
  ASSERT_EQ(tb.value_or(""), "AK=TB=15=");
  std::vector<std::string> events;
  ASSERT_TRUE(stream_points(robot, pts, 0, 20, 15, {}, &events));
  std::vector<std::string> skipped;
  EXPECT_EQ(robot.wait_for("EV=", 30.0, &skipped).value_or(""), "EV=5=20=");
  for (const auto& e : events) EXPECT_NE(e.rfind("EV=5=", 0), 0u) << "underrun while loading";
  ASSERT_NO_FATAL_FAILURE(expect_at_rest_at(robot, pts[19].steps));
  auto st = robot.query_state();
  ASSERT_TRUE(st);
  EXPECT_EQ(st->flags() & (kFlagTrajectory | kFlagMoving | kFlagHalted), kFlagTrajectory)
      << "the trajectory waits for its next point";
  EXPECT_EQ(st->queue_free(), 15);
  // EV=5 comes once: nothing more while it waits
  for (const auto& l : lines_for_sim_ms(robot, 300)) EXPECT_NE(l.rfind("EV=", 0), 0u) << l;
  events.clear();
  ASSERT_TRUE(stream_points(robot, pts, 20, pts.size(), 15, {}, &events));
  std::optional<std::string> done;
  for (const auto& e : events) {
    if (e.rfind("EV=3=", 0) == 0) done = e;
  }
  if (!done) done = robot.wait_for("EV=3=", 60.0);
  EXPECT_EQ(done.value_or(""), "EV=3=59=");
  ASSERT_NO_FATAL_FAILURE(expect_at_rest_at(robot, pts.back().steps));
}

// Every refusal of a trajectory point over the wire carries the code and field of
// protocol.md section 8, and a refused point moves nothing and is not queued.
TEST_F(Promise, TrajectoryPointsAreRefusedWithTheDocumentedCodesAndNothingMoves) {
  ASSERT_TRUE(robot.home());
  ASSERT_EQ(robot.request("TB=2=\n").value_or(""), "AK=TB=15=");
  const std::string z = std::to_string(kHomeZ);
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"TP=0=0=" + z + "=0=0=0=\n", "ER=11=1="},           // dt_ms below 1
      {"TP=0=5001=" + z + "=0=0=0=\n", "ER=11=1="},        // dt_ms above 5000
      {"TP=0=10=24567=0=0=0=\n", "ER=11=2="},              // Z: 100 steps in 10 ms = 10,000/s
      {"TP=0=10=" + z + "=100=0=0=\n", "ER=11=3="},        // J2 too fast
      {"TP=0=10=" + z + "=0=-100=0=\n", "ER=11=4="},       // J3 too fast
      {"TP=0=100=24267=0=0=0=\n", "ER=11=2="},             // 4,000 steps/s from rest in 100 ms
      {"TP=0=1000=" + z + "=0=0=18001=\n", "ER=8=3="},     // wrist above 180 deg
      {"TP=0=1000=" + z + "=0=0=-1=\n", "ER=8=3="},        // wrist below 0
      {"TP=0=1000=" + z + "=0=0=0=18001=\n", "ER=11=6="},  // gripper above 180 deg
      {"TP=1=1000=" + z + "=0=0=0=\n", "ER=10=0="},        // seq 1 before 0
  };
  const Truth before = robot.truth();
  for (const auto& [bad, want] : cases) {
    EXPECT_EQ(robot.request(bad).value_or("timeout"), want) << bad;
  }
  lines_for_sim_ms(robot, 100);
  const Truth after = robot.truth();
  EXPECT_EQ(after.u("steps_z") + after.u("steps_j2") + after.u("steps_j3"),
            before.u("steps_z") + before.u("steps_j2") + before.u("steps_j3"))
      << "a refused point moved a motor";
  // nothing was queued: point 0 is still the one expected, with all 15 slots free
  EXPECT_EQ(robot.request("TP=0=500=" + std::to_string(kHomeZ - 100) + "=0=0=0=\n").value_or(""),
            "AK=TP=14=");
  EXPECT_EQ(robot.request("TP=1=500=" + std::to_string(kHomeZ - 100) + "=0=0=0=\n").value_or(""),
            "AK=TP=13=");
  EXPECT_EQ(robot.wait_for("EV=", 20.0).value_or(""), "EV=3=2=");
  ASSERT_NO_FATAL_FAILURE(expect_at_rest_at(robot, {kHomeZ - 100, 0, 0}));
}

// While a trajectory steps, TB, HM and JG are busy (9); the running trajectory goes on.
// Fifteen points, the queue's size, over 8 s: the whole trajectory is queued by the time the
// test asks, so it is still stepping however slowly the host runs. (With 59 points over 5 s,
// loading ended with about a second of motion left, less in wall time as the emulator runs
// unpaced here; in one CI run, two cores busy, the motion had stopped when the test asked.)
TEST_F(Promise, MotionCommandsAreBusyWhileATrajectoryRuns) {
  ASSERT_TRUE(robot.home());
  const auto pts = plan_points({0.10, 0.8, -0.6, 0.5}, 8.0, 16);
  ASSERT_EQ(pts.size(), 15u);
  ASSERT_TRUE(load_trajectory(robot, pts));
  auto st = robot.query_state();
  ASSERT_TRUE(st);
  ASSERT_EQ(st->flags() & kFlagMoving, kFlagMoving) << "the test needs the trajectory running";
  EXPECT_EQ(robot.request("TB=2=\n").value_or(""), "ER=9=");
  EXPECT_EQ(robot.request("HM=\n").value_or(""), "ER=9=");
  EXPECT_EQ(robot.request("JG=1=10=\n").value_or(""), "ER=9=");
  EXPECT_EQ(robot.wait_for("EV=", 60.0).value_or(""), "EV=3=" + std::to_string(pts.size()) + "=");
  ASSERT_NO_FATAL_FAILURE(expect_at_rest_at(robot, pts.back().steps));
}

// A point sent without credit finds the queue full: ER=6=<free>= (0), and it is not queued;
// resent once a slot is free, it is taken (protocol.md section 9, step 3).
TEST_F(Promise, APointWithoutCreditIsRefusedAsQueueFullAndCanBeResent) {
  ASSERT_TRUE(robot.home());
  // 300 ms per point, one step of Z each, the last two at the same place (it comes to rest):
  // the queue drains slowly
  std::vector<Point> pts;
  for (int k = 0; k < 20; ++k) pts.push_back({300, {kHomeZ - 1 - std::min(k, 18), 0, 0}, 0});
  ASSERT_EQ(robot.request("TB=20=\n").value_or(""), "AK=TB=15=");
  // sent regardless of credit: the queue fills at 15 and the trajectory starts, its first
  // point leaving the queue for the step generator; the point after the next "free 0" finds
  // the queue full
  int refused = -1;
  std::string last_ak;
  for (int k = 0; k < 18 && refused < 0; ++k) {
    const std::string reply = robot.request(tp(k, pts[static_cast<std::size_t>(k)])).value_or("");
    if (reply.rfind("AK=TP=", 0) == 0) {
      last_ak = reply;
    } else {
      EXPECT_EQ(reply, "ER=6=0=") << "point " << k;
      refused = k;
    }
  }
  ASSERT_GE(refused, 15) << "refused before the queue was full";
  EXPECT_EQ(last_ak, "AK=TP=0=") << "the point before had taken the last slot";
  // not queued: the same point, resent once a slot is free, is taken
  std::optional<Report> st;
  for (int i = 0; i < 2000; ++i) {
    st = robot.query_state();
    ASSERT_TRUE(st);
    if (st->queue_free() > 0) break;
  }
  ASSERT_GT(st->queue_free(), 0);
  const auto k0 = static_cast<std::size_t>(refused);
  ASSERT_EQ(robot.request(tp(refused, pts[k0])).value_or("").rfind("AK=TP=", 0), 0u);
  ASSERT_TRUE(stream_points(robot, pts, k0 + 1, pts.size(), 0));
  EXPECT_EQ(robot.wait_for("EV=", 60.0).value_or(""), "EV=3=20=");
  ASSERT_NO_FATAL_FAILURE(expect_at_rest_at(robot, pts.back().steps));
}

// A host that ignores the 64-byte receive window overruns the firmware's receive buffer: each
// line that lost bytes is answered ER=6=0= in its place, every other line gets its own reply,
// in order, and the firmware goes on (protocol.md sections 5 and 8).
TEST_F(Promise, AnOverrunReceiveBufferAnswersEachLostLineInItsPlace) {
  constexpr int kLines = 300;
  std::string burst;
  for (int k = 0; k < kLines; ++k) burst += "PI=" + std::to_string(1000 + k) + "=\n";
  robot.send(burst);  // 3,000 bytes at once
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
  EXPECT_EQ(robot.request("PI=7=\n").value_or(""), "AK=PI=7=") << "no extra reply afterwards";
}

// A report for QS restarts the periodic grid: the next periodic report follows a full period
// after it (docs/firmware.md, State reports), not at the old grid's next point. Paced to real
// time only to place the query inside a period (unpaced, the idle firmware's time runs far
// ahead of the host); it is judged in the device's time.
TEST(PromisePaced, AQueryReportRestartsThePeriodicGrid) {
  Robot robot({"--speed", "1"});
  ASSERT_TRUE(robot.ok()) << robot.error();
  constexpr std::int64_t kPeriodUs = 100000;  // SR=10
  ASSERT_EQ(robot.request("SR=10=\n").value_or(""), "AK=SR=10=");
  for (int attempt = 0; attempt < 5; ++attempt) {
    auto first = robot.wait_for("ST=", 10.0);
    ASSERT_TRUE(first);
    std::vector<Report> reps{*parse_report(*first)};
    std::this_thread::sleep_for(std::chrono::milliseconds(40));
    robot.send("QS=\n");
    while (reps.size() < 4) {
      auto l = robot.line(10.0, true);
      ASSERT_TRUE(l);
      if (auto r = parse_report(*l)) reps.push_back(*r);
    }
    // the reports share one sequence: no number skipped
    for (std::size_t k = 1; k < reps.size(); ++k) {
      ASSERT_EQ(reps[k].seq(), (reps[k - 1].seq() + 1) % 65536);
    }
    // the answer to QS is the one that came early
    std::size_t q = 0;
    for (std::size_t k = 1; k < reps.size(); ++k) {
      const std::int64_t dt = static_cast<std::uint32_t>(reps[k].t_us() - reps[k - 1].t_us());
      if (dt < kPeriodUs - 1000) {
        ASSERT_EQ(q, 0u) << "two reports off the grid";
        q = k;
      }
    }
    if (q == 0 || q + 1 >= reps.size()) continue;  // the query fell on the old grid's point
    const std::int64_t into = static_cast<std::uint32_t>(reps[q].t_us() - reps[q - 1].t_us());
    if (into < 5000) continue;  // too close to the old grid to tell
    const std::int64_t next = static_cast<std::uint32_t>(reps[q + 1].t_us() - reps[q].t_us());
    // the AVR sleeps between its 1 ms clock interrupts at rest: up to 1 ms late, never early
    EXPECT_GE(next, kPeriodUs) << "the QS answer came " << into << " us into a period";
    EXPECT_LE(next, kPeriodUs + 1500) << "the QS answer came " << into << " us into a period";
    return;
  }
  FAIL() << "no QS landed inside a period in 5 attempts";
}

// CF settings are stored in EEPROM: they survive a power cycle (the emulator's --eeprom keeps
// the EEPROM in a file; power_off kills it with no orderly exit), take effect at reset (the
// report rate, key 3), and a block with a bad checksum is ignored for the defaults.
TEST(PromiseEeprom, SettingsSurviveAPowerCycleAndABadChecksumRestoresTheDefaults) {
  const std::string path =
      ::testing::TempDir() + "scaratwin_eeprom_" + std::to_string(::getpid()) + ".bin";
  std::filesystem::remove(path);
  {
    Robot r({"--speed", "0", "--eeprom", path});
    ASSERT_TRUE(r.ok()) << r.error();
    EXPECT_EQ(r.request("CF=7=\n").value_or(""), "AK=CF=1000=") << "a new board's default";
    EXPECT_EQ(r.request("CF=7=2500=\n").value_or(""), "AK=CF=2500=");
    EXPECT_EQ(r.request("CF=3=50=\n").value_or(""), "AK=CF=50=");
    EXPECT_EQ(r.request("CF=3=1001=\n").value_or(""), "ER=11=1=") << "out of range: not stored";
    r.power_off();
  }
  {
    Robot r({"--speed", "0", "--eeprom", path});
    ASSERT_TRUE(r.ok()) << r.error();
    EXPECT_EQ(r.request("CF=7=\n").value_or(""), "AK=CF=2500=");
    EXPECT_EQ(r.request("CF=3=\n").value_or(""), "AK=CF=50=");
    // the stored report rate is the one in effect after the reset: 50 Hz in device time
    std::vector<Report> reps;
    while (reps.size() < 11) {
      auto l = r.line(10.0, true);
      ASSERT_TRUE(l);
      if (auto rep = parse_report(*l)) reps.push_back(*rep);
    }
    for (std::size_t k = 1; k < reps.size(); ++k) {
      ASSERT_EQ(reps[k].seq(), (reps[k - 1].seq() + 1) % 65536) << "a report lost";
    }
    const auto span_us = static_cast<std::uint32_t>(reps.back().t_us() - reps.front().t_us());
    EXPECT_NEAR(static_cast<double>(span_us) / 10.0, 20000.0, 150.0);
    r.power_off();
  }
  {
    // one flipped bit in the stored block: its checksum no longer matches
    std::vector<char> bytes;
    {
      std::ifstream f(path, std::ios::binary);
      bytes.assign(std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>());
    }
    ASSERT_EQ(bytes.size(), 1024u) << "the ATmega328P's EEPROM";
    bytes[2] = static_cast<char>(bytes[2] ^ 0x01);
    std::ofstream(path, std::ios::binary | std::ios::trunc)
        .write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
    Robot r({"--speed", "0", "--eeprom", path});
    ASSERT_TRUE(r.ok()) << r.error();
    EXPECT_EQ(r.request("CF=7=\n").value_or(""), "AK=CF=1000=");
    EXPECT_EQ(r.request("CF=3=\n").value_or(""), "AK=CF=100=");
  }
  std::filesystem::remove(path);
}

// docs/firmware.md: the jog buttons are sampled every 5 ms and debounced over 20 ms. A press
// of 12 ms (at most three samples) is a bounce: no event, no step; one of 40 ms is a press.
TEST_F(Promise, AJogButtonPressShorterThanTheDebounceIsABounce) {
  const auto j2 = robot.truth().i("j2");
  ASSERT_EQ(robot.side("press j2+ 12"), "OK press j2+ 12");
  for (const std::string& l : lines_for_sim_ms(robot, 300)) {
    EXPECT_EQ(l.rfind("EV=4=", 0), std::string::npos) << l;
  }
  EXPECT_EQ(robot.truth().i("j2"), j2) << "a bounce moved J2";
  ASSERT_EQ(robot.side("press j2+ 40"), "OK press j2+ 40");
  bool pressed = false;
  for (const std::string& l : lines_for_sim_ms(robot, 300)) pressed = pressed || l == "EV=4=2=";
  EXPECT_TRUE(pressed) << "a 40 ms press is a press of J2+";
}

}  // namespace
}  // namespace scaratwin::test
