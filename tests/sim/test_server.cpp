// The simulator's TCP server: a real client on loopback, replies in order, images, and
// malformed packets that get an error reply and leave the scene untouched.
#include <utility>

#include <chrono>
#include <cstdint>
#include <filesystem>
#include <string>
#include <thread>
#include <tuple>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include "scaratwin/config/robot_config.hpp"
#include "scaratwin/sim/camera.hpp"
#include "scaratwin/sim/server.hpp"
#include "scaratwin/sim/world.hpp"
#include "scaratwin/transport/tcp.hpp"
#include "scaratwin/vision/vision.hpp"
#include "two_arms_server.hpp"

namespace scaratwin::sim {
namespace {

using transport::Duration;

class SimServerTest : public ::testing::Test {
 protected:
  void SetUp() override {
    auto m = load_robot_config(SCARATWIN_CONFIG_FILE);
    ASSERT_TRUE(m.ok());
    auto w = World::create(*m);
    ASSERT_TRUE(w.ok()) << w.error().message;
    world_ = std::move(*w);
    ServerOptions o;
    o.port = 0;
    auto s = SimServer::create(*world_, o);
    ASSERT_TRUE(s.ok()) << s.error().message;
    server_ = std::move(*s);
    transport::TcpClientOptions c;
    c.port = server_->port();
    auto client = transport::TcpClient::create(c);
    ASSERT_TRUE(client.ok());
    client_ = std::move(*client);
    ASSERT_TRUE(client_->wait_connected(Duration(3000)).ok());
  }

  // The next `n` frames from the simulator, as text lines ("IM,<n>," for images).
  std::vector<transport::RxPacket> receive(int n) {
    std::vector<transport::RxPacket> out;
    for (int i = 0; i < n; ++i) {
      auto p = client_->receive(Duration(5000));
      EXPECT_TRUE(p.ok()) << "reply " << i << " missing";
      if (!p.ok()) break;
      out.push_back(std::move(*p));
    }
    return out;
  }
  std::vector<std::string> lines(int n) {
    std::vector<std::string> out;
    for (auto& p : receive(n)) out.push_back(p.line);
    return out;
  }

  std::unique_ptr<World> world_;
  std::unique_ptr<SimServer> server_;
  std::unique_ptr<transport::TcpClient> client_;
};

TEST_F(SimServerTest, MixedWriteIsAnsweredInOrder) {
  ASSERT_TRUE(client_
                  ->send("HI,1,\nPI,42,\nJD,17,5000123,80,12.5,-30.25,90,\nSC,green,150,20,\n"
                         "SC,red,200,60,\nOP,\nQS,\n")
                  .ok());
  const auto r = lines(9);
  ASSERT_EQ(r.size(), 9u);
  EXPECT_EQ(r[0], "HI,1,scaratwin-sim,0.1.0,");
  EXPECT_EQ(r[1], "AK,PI,42,");
  EXPECT_EQ(r[2].rfind("JA,17,", 0), 0u) << r[2];
  EXPECT_EQ(r[3].rfind("AK,SC,", 0), 0u) << r[3];
  EXPECT_EQ(r[4].rfind("AK,SC,", 0), 0u) << r[4];
  EXPECT_EQ(r[5].rfind("OP,", 0), 0u);
  EXPECT_EQ(r[6].rfind("OP,", 0), 0u);
  EXPECT_EQ(r[7], "AK,OP,2,");
  EXPECT_EQ(r[8].rfind("ST,0,", 0), 0u) << r[8];
  EXPECT_NE(r[8].find(",80,12.5,-30.25,90,0,-1,mirror,"), std::string::npos) << r[8];
  const Snapshot s = world_->snapshot();
  EXPECT_NEAR(s.joints[0], 0.08, 1e-12);
  EXPECT_EQ(s.cubes.size(), 2u);
}

TEST_F(SimServerTest, CameraShootSendsAPngOfTheRequestedSize) {
  ASSERT_TRUE(client_->send("CS,320,240,\nCS,\n").ok());
  auto r = receive(2);
  ASSERT_EQ(r.size(), 2u);
  const std::pair<int, int> sizes[] = {
      {320, 240}, {world_->robot().scene.camera.width_px, world_->robot().scene.camera.height_px}};
  for (int i = 0; i < 2; ++i) {
    ASSERT_EQ(r[i].kind, transport::FrameKind::kBinary);
    EXPECT_EQ(r[i].line, "IM," + std::to_string(r[i].payload.size()) + ",");
    auto img = decode_png(r[i].payload);
    ASSERT_TRUE(img.ok()) << img.error().message;
    EXPECT_EQ(img->width, sizes[i].first);
    EXPECT_EQ(img->height, sizes[i].second);
  }
  // beyond the offscreen buffer: refused, and the link goes on
  ASSERT_TRUE(client_->send("CS,5000,10,\nPI,\n").ok());
  EXPECT_EQ(lines(2), (std::vector<std::string>{"ER,11,0,", "AK,PI,"}));
}

TEST_F(SimServerTest, MalformedPacketsGetErrorsAndLeaveTheSceneUntouched) {
  ASSERT_TRUE(client_->send("SC,blue,120,-10,\nJD,1,0,80,10,20,30,\n").ok());
  ASSERT_EQ(lines(2).size(), 2u);
  world_->set_paused(true);
  world_->start();
  const Snapshot before = world_->snapshot();
  const std::string bad =
      "JD,1,2,\n"                     // wrong field count
      "XX,\n"                         // unknown code
      "JD,1,nan,0,0,0,0,\n"           // bad number
      "JD,2,5,1e3,0,0,0,\n"           // exponent
      "SC,purple,100,0,\n"            // unknown colour
      "SC,red,9000,0,\n"              // off the table
      "SC,red,120,-10,\n"             // on the blue cube
      "OP,99,\n"                      // no such object
      "TJ,3,5,80,0,0,0,\n"            // simulate-mode command in mirror mode
      "MD,sideways,\n"                // unknown mode
      "GR,7,\n"                       // not 0 or 1
      "JD 1 2 3\n"                    // no delimiters
      "HI,2,\n"                       // wrong protocol version
      "IM,3,\nabc"                    // an image sent to the simulator
      + std::string(600, 'J') + "\n"  // too long
      + "\x01\x02,\n";                // control bytes
  ASSERT_TRUE(client_->send(bad).ok());
  const auto r = lines(16);
  ASSERT_EQ(r.size(), 16u);
  for (const std::string& line : r) EXPECT_EQ(line.rfind("ER,", 0), 0u) << line;
  EXPECT_EQ(r[0], "ER,4,2,");
  EXPECT_EQ(r[1].rfind("ER,3,", 0), 0u);
  EXPECT_EQ(r[2], "ER,5,1,");
  EXPECT_EQ(r[6], "ER,11,1,");
  EXPECT_EQ(r[8].rfind("ER,9,", 0), 0u);
  EXPECT_EQ(r[12], "ER,13,1,");
  EXPECT_EQ(r[14], "ER,1,512,");
  const Snapshot after = world_->snapshot();
  EXPECT_EQ(after.time_s, before.time_s);
  EXPECT_EQ(after.joints, before.joints);
  EXPECT_EQ(after.mode, before.mode);
  EXPECT_EQ(after.gripper_closed, before.gripper_closed);
  ASSERT_EQ(after.cubes.size(), before.cubes.size());
  for (std::size_t i = 0; i < after.cubes.size(); ++i) {
    EXPECT_EQ(after.cubes[i].pos_m, before.cubes[i].pos_m);
    EXPECT_EQ(after.cubes[i].quat_wxyz, before.cubes[i].quat_wxyz);
  }
  // and a good packet right after is served normally
  ASSERT_TRUE(client_->send("PI,1,\n").ok());
  EXPECT_EQ(lines(1), std::vector<std::string>{"AK,PI,1,"});
}

// A joint value no robot can have (1000 km up) is refused with exactly one reply, nothing is
// applied, and the next lines (QS among them) are answered as usual; a value just off the
// limits is still mirrored (a robot off its limits is shown as it is).
TEST_F(SimServerTest, ImpossibleJointValueIsRefusedWithOneReplyAndNothingApplied) {
  ASSERT_TRUE(client_->send("JD,1,0,80,10,20,30,\n").ok());
  ASSERT_EQ(lines(1)[0].rfind("JA,1,", 0), 0u);
  const Snapshot before = world_->snapshot();
  ASSERT_TRUE(client_
                  ->send("JD,1,2,999999999.999999,0,0,0,\nQS,\nJD,3,4,80,-999999,0,0,\n"
                         "JD,5,6,80,0,0,400000,\nMD,simulate,\nTJ,7,8,80,0,999999,0,\n"
                         "MD,mirror,\nPI,9,\n")
                  .ok());
  const auto r = lines(8);
  ASSERT_EQ(r.size(), 8u);
  EXPECT_EQ(r[0], "ER,11,2,");
  EXPECT_EQ(r[1].rfind("ST,", 0), 0u) << r[1];
  EXPECT_NE(r[1].find(",80,10,20,30,"), std::string::npos) << r[1];
  EXPECT_EQ(r[2], "ER,11,3,");
  EXPECT_EQ(r[3], "ER,11,5,");
  EXPECT_EQ(r[4], "AK,MD,");
  EXPECT_EQ(r[5], "ER,11,4,");
  EXPECT_EQ(r[6], "AK,MD,");
  EXPECT_EQ(r[7], "AK,PI,9,") << "one reply per line";
  EXPECT_FALSE(client_->receive(Duration(200)).ok()) << "an extra reply";
  EXPECT_EQ(world_->snapshot().joints, before.joints);
  EXPECT_EQ(world_->snapshot().warnings_total, before.warnings_total);
  // just beyond a limit (q2 limit 115 deg): mirrored, with its warning
  ASSERT_TRUE(client_->send("JD,10,0,80,300,0,0,\nQS,\n").ok());
  const auto ok = lines(3);
  ASSERT_EQ(ok.size(), 3u);
  EXPECT_EQ(ok[0], "JW,2,300,");
  EXPECT_EQ(ok[1].rfind("JA,10,", 0), 0u) << ok[1];
  EXPECT_NE(ok[2].find(",80,300,0,0,"), std::string::npos) << ok[2];
}

// A line longer than the link's 512 bytes is refused when the limit is passed, not only at
// its newline (which a hostile or broken peer may never send); the link then resyncs.
TEST_F(SimServerTest, OverlongLineIsRefusedAtTheLimitBeforeItsNewline) {
  ASSERT_TRUE(client_->send(std::string(600, 'J')).ok());
  const auto r = lines(1);
  ASSERT_EQ(r.size(), 1u);
  EXPECT_EQ(r[0], "ER,1,512,");
  ASSERT_TRUE(client_->send(std::string(100, 'J') + "\nPI,3,\n").ok());
  EXPECT_EQ(lines(1), std::vector<std::string>{"AK,PI,3,"});
}

TEST_F(SimServerTest, JointLimitWarningComesBeforeTheReply) {
  const std::string reply = server_->handle_line("JD,4,0,80,130,0,0,");
  EXPECT_EQ(reply.rfind("JW,2,130,\nJA,4,", 0), 0u) << reply;
  EXPECT_EQ(world_->snapshot().warnings_total, 1u);
  EXPECT_EQ(server_->counters().warnings_sent, 1u);
}

// A joint that stays beyond its limit is one warning, not one per frame (a robot resting at
// its switch just beyond a soft limit made 100 a second, 1,938 on the page at a demo's end);
// back inside and out again is the next one; a new hub's hello starts afresh.
TEST_F(SimServerTest, AJointBeyondItsLimitFrameAfterFrameIsOneWarning) {
  EXPECT_EQ(server_->handle_line("JD,4,0,80,130,0,0,").rfind("JW,2,130,\nJA,4,", 0), 0u);
  EXPECT_EQ(server_->handle_line("JD,5,0,80,131,0,0,").rfind("JA,5,", 0), 0u);
  EXPECT_EQ(server_->handle_line("JD,6,0,125,131,0,0,").rfind("JW,1,125,\nJA,6,", 0), 0u);
  EXPECT_EQ(server_->handle_line("JD,7,0,80,100,0,0,").rfind("JA,7,", 0), 0u);
  EXPECT_EQ(server_->handle_line("JD,8,0,80,132,0,0,").rfind("JW,2,132,\nJA,8,", 0), 0u);
  EXPECT_EQ(world_->snapshot().warnings_total, 3u);
  EXPECT_EQ(server_->handle_line("HI,1,"), "HI,1,scaratwin-sim,0.1.0,\n");
  EXPECT_EQ(server_->handle_line("JD,9,0,80,132,0,0,").rfind("JW,2,132,\nJA,9,", 0), 0u);
  EXPECT_EQ(world_->snapshot().warnings_total, 4u);
}

// While the hub says the robot homes (TW,homing), joints beyond their soft limits are not
// warnings (homing passes them on the way to the endstops, by design); the next phase, or a new
// hub's hello, notes them again.
TEST_F(SimServerTest, NoLimitWarningWhileTheRobotHomes) {
  EXPECT_EQ(server_->handle_line("TW,homing,"), "AK,TW,\n");
  const std::string homing = server_->handle_line("JD,4,0,80,130,0,0,");
  EXPECT_EQ(homing.rfind("JA,4,", 0), 0u) << homing;
  EXPECT_EQ(world_->snapshot().warnings_total, 0u);
  EXPECT_EQ(server_->handle_line("TW,mirror,"), "AK,TW,\n");
  EXPECT_EQ(server_->handle_line("JD,5,0,80,131,0,0,").rfind("JW,2,131,\nJA,5,", 0), 0u);
  EXPECT_EQ(world_->snapshot().warnings_total, 1u);
  EXPECT_EQ(server_->handle_line("TW,homing,"), "AK,TW,\n");
  EXPECT_EQ(server_->handle_line("HI,1,"), "HI,1,scaratwin-sim,0.1.0,\n");
  EXPECT_EQ(server_->handle_line("JD,6,0,80,132,0,0,").rfind("JW,2,132,\nJA,6,", 0), 0u);
  EXPECT_EQ(world_->snapshot().warnings_total, 2u);
}

// The hello's description hash (docs/protocol.md section 11.2): a hub's hello that carries
// one gets the simulator's own in the reply, whatever it is (the hub compares); a v1 hello
// gets a v1 reply.
TEST_F(SimServerTest, AHelloWithADescriptionHashIsAnsweredWithTheSimulatorsOwn) {
  const std::string own = description_hash(world_->robot());
  ASSERT_EQ(own.size(), 8u);
  EXPECT_EQ(server_->handle_line("HI,1,control,-," + own + ","),
            "HI,1,scaratwin-sim,0.1.0," + own + ",\n");
  EXPECT_EQ(server_->handle_line("HI,1,control,-,0badf00d,"),
            "HI,1,scaratwin-sim,0.1.0," + own + ",\n");
  EXPECT_EQ(server_->handle_line("HI,1,"), "HI,1,scaratwin-sim,0.1.0,\n");
  EXPECT_EQ(server_->handle_line("HI,1,control,-,0BADF00D,"), "ER,11,3,\n");
}

// Protocol v2's robot index (docs/protocol.md section 11.3): the simulator has one robot,
// index 0 (or none given); a packet for any other robot is ER,19,1, (no such robot; it has 1)
// and nothing of it is applied.
TEST_F(SimServerTest, APacketForARobotTheSimulatorDoesNotHaveIsRefused) {
  EXPECT_EQ(server_->handle_line("JD,4,0,80,10,0,0,0,").rfind("JA,4,", 0), 0u);
  const std::string before = server_->handle_line("QS,");
  ASSERT_EQ(before.rfind("ST,", 0), 0u) << before;
  EXPECT_NE(before.find(",80,10,0,0,"), std::string::npos) << before;
  for (const char* line : {"JD,5,0,90,20,0,0,1,", "TJ,5,0,90,20,0,0,2,", "MD,simulate,1,",
                           "GR,1,1,", "QS,1,", "SP,3,", "TW,control,1,"}) {
    EXPECT_EQ(server_->handle_line(line), "ER,19,1,\n") << line;
  }
  const std::string after = server_->handle_line("QS,0,");
  ASSERT_EQ(after.rfind("ST,", 0), 0u) << after;
  EXPECT_NE(after.find(",80,10,0,0,0,-1,mirror,"), std::string::npos) << "nothing applied\n"
                                                                      << after;
}

// A workcell of two robots (config/two_arms.toml): each robot-addressed packet goes to the
// robot whose index it carries, and its reply carries that index (none for robot 0); robot 2
// is ER,19,2, (it has two) and nothing of it is applied.
TEST(SimServerWorkcell, EachPacketGoesToTheRobotItNames) {
  test::TwoArmsServer cell;
  ASSERT_NO_FATAL_FAILURE(test::start_two_arms_server(&cell));
  SimServer& server = *cell.server;
  World* w = cell.world.get();

  const std::string ja = server.handle_line("JD,4,0,80,10,0,0,1,");
  EXPECT_EQ(ja.rfind("JA,4,", 0), 0u) << ja;
  ASSERT_GE(ja.size(), 4u);
  EXPECT_EQ(ja.substr(ja.size() - 4), ",1,\n") << ja;
  // robot 1 where it was told; robot 0 still at home (d1 120 mm)
  std::string st1 = server.handle_line("QS,1,");
  EXPECT_NE(st1.find(",80,10,0,0,0,-1,mirror,1,\n"), std::string::npos) << st1;
  std::string st0 = server.handle_line("QS,");
  EXPECT_NE(st0.find(",120,0,0,0,0,-1,mirror,\n"), std::string::npos) << st0;
  const Snapshot snap = w->snapshot();
  ASSERT_EQ(snap.robots.size(), 2u);
  EXPECT_EQ(snap.robots[1].name, "right");
  EXPECT_NEAR(snap.robots[1].joints[0], 0.080, 1e-12);
  EXPECT_NEAR(snap.robots[0].joints[0], 0.120, 1e-12);

  // modes are each robot's: robot 1 simulates, robot 0 still takes joint data
  EXPECT_EQ(server.handle_line("MD,simulate,1,"), "AK,MD,\n");
  EXPECT_EQ(server.handle_line("JD,5,0,90,20,0,0,1,"), "ER,9,\n");
  EXPECT_EQ(server.handle_line("JD,6,0,90,20,0,0,").rfind("JA,6,", 0), 0u);
  st1 = server.handle_line("QS,1,");
  EXPECT_NE(st1.find(",simulate,1,\n"), std::string::npos) << st1;
  EXPECT_EQ(server.handle_line("GR,1,1,"), "GR,1,-1,1,\n");
  EXPECT_EQ(server.handle_line("GR,0,1,"), "GR,0,-1,1,\n");

  // robot 2: no such robot, nothing applied
  for (const char* line : {"JD,7,0,50,30,0,0,2,", "MD,simulate,2,", "QS,2,", "SP,2,"}) {
    EXPECT_EQ(server.handle_line(line), "ER,19,2,\n") << line;
  }
  st0 = server.handle_line("QS,0,");
  EXPECT_NE(st0.find(",90,20,0,0,0,-1,mirror,\n"), std::string::npos) << st0;
}

TEST_F(SimServerTest, SimulateModeFollowsTargetsAndGrasps) {
  world_->start();
  ASSERT_TRUE(client_->send("MD,simulate,\nSC,red,150,0,\nJD,1,0,80,0,0,0,\n").ok());
  const auto r = lines(3);
  EXPECT_EQ(r[0], "AK,MD,");
  EXPECT_EQ(r[2].rfind("ER,9,", 0), 0u);  // mirror data refused in simulate mode
  ASSERT_TRUE(client_->send("TJ,1,0,47,0,0,0,\n").ok());
  const auto ja = lines(1);
  ASSERT_EQ(ja[0].rfind("JA,1,", 0), 0u);
  // d1 0.047 puts the tool at the grasp height over x = 0.067 + 0.187 = 0.254: no cube there.
  // Judged after 0.6 s of simulated time (the wall clock only guards against a hang: a loaded
  // machine slows the simulation, it does not change where it is 0.6 s later)
  const double applied_s = world_->snapshot().time_s;
  const auto guard = std::chrono::steady_clock::now() + std::chrono::seconds(60);
  while (world_->snapshot().time_s < applied_s + 0.6 && std::chrono::steady_clock::now() < guard) {
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  ASSERT_GE(world_->snapshot().time_s, applied_s + 0.6) << "the simulation did not run";
  EXPECT_NEAR(world_->snapshot().joints[0], 0.047, 1e-3);
  ASSERT_TRUE(client_->send("GR,1,\nGR,0,\n").ok());
  EXPECT_EQ(lines(2), (std::vector<std::string>{"GR,1,-1,", "GR,0,-1,"}));
}

TEST(SimServerMax, TargetStreamRunsInLockstepAsFastAsPossible) {
  auto m = load_robot_config(SCARATWIN_CONFIG_FILE);
  ASSERT_TRUE(m.ok());
  WorldOptions wo;
  wo.speed = 0.0;
  wo.camera = false;
  auto world = World::create(*m, {}, wo);
  ASSERT_TRUE(world.ok());
  ServerOptions o;
  o.port = 0;
  auto server = SimServer::create(**world, o);
  ASSERT_TRUE(server.ok());
  (*world)->start();
  // paused while the stream is sent, so that it starts at a known simulation time
  (*world)->set_paused(true);
  const double t_start = (*world)->snapshot().time_s;
  EXPECT_EQ((*server)->handle_line("MD,simulate,"), "AK,MD,\n");
  // 3 s of targets, 20 ms apart, starting near the wrap of the 32-bit microsecond clock
  const std::uint32_t t0 = 4294000000u;
  for (int i = 0; i <= 150; ++i) {
    const std::uint32_t t = t0 + static_cast<std::uint32_t>(20000 * i);
    const std::string tj = "TJ," + std::to_string(i) + "," + std::to_string(t) + "," +
                           std::to_string(120 - i / 3) + ",0,0,0,";
    ASSERT_EQ((*server)->handle_line(tj).rfind("JA,", 0), 0u);
  }
  // the simulation catches up with the last target and waits there
  (*world)->set_paused(false);
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(30);
  while ((*world)->snapshot().time_s < t_start + 3.0 - 1e-9 &&
         std::chrono::steady_clock::now() < deadline) {
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  const double t_end = (*world)->snapshot().time_s;
  EXPECT_NEAR(t_end, t_start + 3.0, 1e-9);
  std::this_thread::sleep_for(std::chrono::milliseconds(100));
  EXPECT_EQ((*world)->snapshot().time_s, t_end);  // no stepping past the stream
  EXPECT_NEAR((*world)->snapshot().joints[0], 0.07, 2e-3);
  EXPECT_EQ((*server)->handle_line("SP,"), "AK,SP,\n");
}

// --speed max in a workcell (config/two_arms.toml): any robot's stream sets the pace, and the
// simulation never runs past the last target of any robot's stream. Robot 1 alone streams 3 s
// of targets: the simulation catches up with them and waits there (robot 0 is idle). Then
// robot 0 streams 1 s and robot 1 3 s more: it stops at robot 0's last target.
TEST(SimServerMax, EveryRobotsStreamSetsThePaceOfAWorkcell) {
  test::TwoArmsServer cell;
  ASSERT_NO_FATAL_FAILURE(test::start_two_arms_server(&cell, 0.0));
  SimServer& server = *cell.server;
  World& world = *cell.world;
  world.start();
  world.set_paused(true);
  EXPECT_EQ(server.handle_line("MD,simulate,"), "AK,MD,\n");
  EXPECT_EQ(server.handle_line("MD,simulate,1,"), "AK,MD,\n");
  // targets 20 ms apart on the senders' clocks, d1 from 120 mm down by 1 mm every 60 ms
  const auto send = [&server](int robot, int from, int to, std::uint32_t t0) {
    for (int i = from; i <= to; ++i) {
      const std::string tj = fmt::format("TJ,{},{},{},0,0,0,{}", i, t0 + 20000u * i, 120 - i / 3,
                                         robot == 0 ? "" : fmt::format("{},", robot));
      const std::string ja = server.handle_line(tj);
      ASSERT_EQ(ja.rfind("JA,", 0), 0u) << tj << " -> " << ja;
    }
  };
  const auto settle_at = [&world](double t_s) {
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(30);
    while (world.snapshot().time_s < t_s - 1e-9 && std::chrono::steady_clock::now() < deadline) {
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    const double reached = world.snapshot().time_s;
    std::this_thread::sleep_for(std::chrono::milliseconds(150));
    return std::make_pair(reached, world.snapshot().time_s);
  };
  const double t_start = world.snapshot().time_s;
  ASSERT_NO_FATAL_FAILURE(send(1, 0, 150, 1000000u));
  world.set_paused(false);
  auto [reached, later] = settle_at(t_start + 3.0);
  EXPECT_NEAR(reached, t_start + 3.0, 1e-9) << "robot 1's stream alone";
  EXPECT_EQ(later, reached) << "no stepping past robot 1's last target";
  EXPECT_NEAR(world.snapshot().robots[1].joints[0], 0.070, 2e-3);

  world.set_paused(true);
  const double t_both = world.snapshot().time_s;
  ASSERT_NO_FATAL_FAILURE(send(0, 0, 50, 7000000u));     // robot 0: 1 s from now
  ASSERT_NO_FATAL_FAILURE(send(1, 151, 300, 1000000u));  // robot 1: to 6 s, 3 s from now
  world.set_paused(false);
  std::tie(reached, later) = settle_at(t_both + 1.0);
  EXPECT_NEAR(reached, t_both + 1.0, 1e-9) << "robot 0's last target comes first";
  EXPECT_EQ(later, reached) << "no stepping past robot 0's last target";
  EXPECT_EQ(server.handle_line("SP,"), "AK,SP,\n");
  EXPECT_EQ(server.handle_line("SP,1,"), "AK,SP,\n");
}

// TW: the hub says which of the twin's modes it runs; the server hands it on (to the UI) as
// a name, "" for none, and refuses a phase it does not know without handing anything on.
TEST(SimServerPhase, HandsTheTwinPhaseOn) {
  auto m = load_robot_config(SCARATWIN_CONFIG_FILE);
  ASSERT_TRUE(m.ok());
  WorldOptions wo;
  wo.camera = false;
  auto world = World::create(*m, {}, wo);
  ASSERT_TRUE(world.ok());
  std::vector<std::string> phases;
  ServerOptions o;
  o.port = 0;
  o.on_twin_phase = [&phases](const std::string& p) { phases.push_back(p); };
  auto server = SimServer::create(**world, o);
  ASSERT_TRUE(server.ok());
  EXPECT_EQ((*server)->handle_line("TW,control,"), "AK,TW,\n");
  EXPECT_EQ((*server)->handle_line("TW,prediction,"), "AK,TW,\n");
  EXPECT_EQ((*server)->handle_line("TW,homing,"), "AK,TW,\n");
  EXPECT_EQ((*server)->handle_line("TW,replay,"), "ER,11,0,\n");
  EXPECT_EQ((*server)->handle_line("TW,none,"), "AK,TW,\n");
  EXPECT_EQ(phases, (std::vector<std::string>{"control", "prediction", "homing", ""}));
}

// A hub's hello and a mode switch tell the link figures that a new stream of joint frames
// begins (its sequence numbers do not continue the last one's); nothing else does, and the
// hook runs before the frames that follow, in order with them.
TEST(SimServerStream, HelloAndModeSwitchStartANewStreamOfFrames) {
  auto m = load_robot_config(SCARATWIN_CONFIG_FILE);
  ASSERT_TRUE(m.ok());
  WorldOptions wo;
  wo.camera = false;
  auto world = World::create(*m, {}, wo);
  ASSERT_TRUE(world.ok());
  std::vector<std::string> events;
  ServerOptions o;
  o.port = 0;
  o.on_new_stream = [&events](int robot) { events.push_back("new" + std::to_string(robot)); };
  o.on_joint_frame = [&events](const JointFrame& f) { events.push_back(std::to_string(f.seq)); };
  auto server = SimServer::create(**world, o);
  ASSERT_TRUE(server.ok());
  EXPECT_EQ((*server)->handle_line("HI,1,").rfind("HI,1,", 0), 0u);
  EXPECT_EQ((*server)->handle_line("JD,5,0,80,0,0,0,").rfind("JA,5,", 0), 0u);
  EXPECT_EQ((*server)->handle_line("PI,1,"), "AK,PI,1,\n");
  EXPECT_EQ((*server)->handle_line("TW,mirror,"), "AK,TW,\n");
  EXPECT_EQ((*server)->handle_line("JD,6,0,80,0,0,0,").rfind("JA,6,", 0), 0u);
  EXPECT_EQ((*server)->handle_line("MD,mirror,"), "AK,MD,\n");
  EXPECT_EQ((*server)->handle_line("JD,900,0,80,0,0,0,").rfind("JA,900,", 0), 0u);
  EXPECT_EQ((*server)->handle_line("HI,2,"), "ER,13,1,\n");  // refused: no new stream
  EXPECT_EQ(events, (std::vector<std::string>{"new0", "5", "6", "new0", "900"}));
}

}  // namespace
}  // namespace scaratwin::sim
