// The control statements and the channels under them, against protocol-speaking peers over a
// pty (device) and a TCP socket (simulator).
#include "scaratwin/transport/statements.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <random>

#include "eventually.hpp"
#include "peers.hpp"
#include "scaratwin/core/units.hpp"
#include "scaratwin/kinematics/motor.hpp"
#include "scaratwin/transport/serial.hpp"
#include "scaratwin/transport/tcp.hpp"

namespace scaratwin::transport {
namespace {

using testing::DevicePeer;
using testing::SimPeer;
constexpr Duration kWait{5000};

template <class T>
bool eventually_size(std::mutex& m, const std::vector<T>& v, std::size_t n) {
  for (int i = 0; i < 1000; ++i) {
    {
      std::lock_guard lock(m);
      if (v.size() >= n) return true;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  return false;
}

// A twin wired to both peers.
struct Rig {
  RobotModel model = paper_robot();
  DevicePeer device;
  SimPeer sim;
  std::unique_ptr<SerialLink> serial;
  std::unique_ptr<TcpClient> tcp;
  std::unique_ptr<RobotChannel> robot;
  std::unique_ptr<SimChannel> simc;
  std::unique_ptr<Twin> twin;

  explicit Rig(ChannelOptions sim_options = {}) {
    SerialOptions so;
    so.device = device.path();
    serial = std::move(SerialLink::create(so).value());
    TcpClientOptions to;
    to.port = sim.port();
    to.link.reconnect_min = Duration{20};
    to.link.reconnect_max = Duration{50};
    tcp = std::move(TcpClient::create(to).value());
    robot = std::make_unique<RobotChannel>(*serial, robot_channel_defaults());
    simc = std::make_unique<SimChannel>(*tcp, sim_options);
    twin = std::make_unique<Twin>(model, robot.get(), simc.get());
  }
  bool up() { return serial->wait_connected(kWait) && tcp->wait_connected(kWait); }
};

TEST(Statements, ReadPhysicalJointsConvertsStepsAndStoresThem) {
  Rig rig;
  ASSERT_TRUE(rig.up());
  auto j = rig.twin->read_physical_joints();
  ASSERT_TRUE(j) << j.error().message;
  const JointVector want = motors_to_joints(rig.model, {1000, -500, 300}, rad_to_deg(0.5));
  for (int i = 0; i < 3; ++i) EXPECT_NEAR(j->q[i], want[i], 1e-9) << i;
  EXPECT_NEAR(j->q[3], want[3], deg_to_rad(0.01));  // the wire carries centidegrees
  EXPECT_EQ(j->seq, 100);
  EXPECT_EQ(j->queue_free, DevicePeer::kSlots);
  EXPECT_GT(j->rx_system_us, 0);
  {
    std::lock_guard lock(rig.device.m);
    rig.device.steps = {2000, 0, 0};
  }
  auto j2 = rig.twin->read_physical_joints();
  ASSERT_TRUE(j2);
  EXPECT_NEAR(j2->q[0], 2000.0 / rig.model.motors.z.steps_per_unit, 1e-12);
  auto log = rig.twin->stored_joints();
  ASSERT_EQ(log.size(), 2u);
  EXPECT_EQ(log[1].seq, 101);
  EXPECT_EQ(rig.serial->counters().lost_packets, 0u);
}

TEST(Statements, StateSequenceGapsAreCountedAsLost) {
  Rig rig;
  ASSERT_TRUE(rig.up());
  rig.device.seq_step = 3;  // two reports "lost" between each
  for (int i = 0; i < 4; ++i) ASSERT_TRUE(rig.twin->read_physical_joints());
  EXPECT_EQ(rig.serial->counters().lost_packets, 6u);
  EXPECT_EQ(rig.robot->lost_packets(), 6u);
}

TEST(Statements, SendJointsToVirtualWaitsForTheApply) {
  Rig rig;
  ASSERT_TRUE(rig.up());
  const JointVector q{0.1, deg_to_rad(12.5), deg_to_rad(-30.25), deg_to_rad(90)};
  for (int i = 0; i < 3; ++i) {
    auto a = rig.twin->send_joints_to_virtual(q);
    ASSERT_TRUE(a) << a.error().message;
    EXPECT_EQ(a->seq, i);
    EXPECT_GE(a->latency_us, 0);
    EXPECT_GE(a->round_trip_us, 0);
    EXPECT_LT(a->latency_us, 5'000'000);
  }
  std::lock_guard lock(rig.sim.m);
  ASSERT_EQ(rig.sim.joints.size(), 3u);
  for (int i = 0; i < kNumJoints; ++i) EXPECT_NEAR(rig.sim.joints[2].q[i], q[i], 1e-6);
}

TEST(Statements, ObjectPositionFromTheVirtualScene) {
  Rig rig;
  ASSERT_TRUE(rig.up());
  {
    std::lock_guard lock(rig.sim.m);
    rig.sim.objects = {{1, CubeColor::kRed, 0.15, 0.02, -0.03, 0.1},
                       {2, CubeColor::kBlue, 0.2, -0.05, -0.03, 0.0}};
  }
  auto p = rig.twin->object_position(2);
  ASSERT_TRUE(p) << p.error().message;
  EXPECT_EQ(p->color, CubeColor::kBlue);
  EXPECT_NEAR(p->x_m, 0.2, 1e-6);
  EXPECT_NEAR(p->y_m, -0.05, 1e-6);
  auto all = rig.twin->object_positions();
  ASSERT_TRUE(all);
  EXPECT_EQ(all->size(), 2u);
  auto missing = rig.twin->object_position(9);
  ASSERT_FALSE(missing);
  EXPECT_NE(missing.error().message.find("9"), std::string::npos);
}

TEST(Statements, LoadTrajectoryHonoursCreditAndTheReceiveWindow) {
  Rig rig;
  ASSERT_TRUE(rig.up());
  const JointVector q0 = rig.model.home;
  const JointVector q1{0.08, deg_to_rad(40), deg_to_rad(-60), deg_to_rad(30)};
  JointTrajectory traj = quintic(q0, q1, 0.6, 60);
  traj.events.push_back({0.3, GripperAction::kGrip});
  auto load = rig.twin->load_trajectory(traj);
  ASSERT_TRUE(load) << load.error().message;
  EXPECT_EQ(load->points, 60);
  EXPECT_EQ(load->device_slots, DevicePeer::kSlots);
  EXPECT_GT(load->credit_polls, 0);  // 60 points through 8 slots needs freed slots
  std::lock_guard lock(rig.device.m);
  EXPECT_EQ(rig.device.overflows, 0);
  EXPECT_LE(rig.device.max_unanswered, kSerialWindowBytes);
  ASSERT_EQ(rig.device.received.size(), 60u);
  int with_grip = 0;
  for (std::size_t k = 0; k < 60; ++k) {
    const auto& p = rig.device.received[k];
    EXPECT_EQ(p.seq, static_cast<std::int32_t>(k));
    // the position at the whole millisecond the device reaches the point (0.6 s / 59 is no
    // whole number of ms): the quintic evaluated there, to within the rounding of one step
    const double t = static_cast<double>(std::llround(traj.samples[k].t_s * 1000.0)) / 1000.0;
    const double tau = std::clamp(t / 0.6, 0.0, 1.0);
    const double blend = tau * tau * tau * (10.0 - 15.0 * tau + 6.0 * tau * tau);
    JointVector q;
    for (int j = 0; j < kNumJoints; ++j) q[j] = q0[j] + (q1[j] - q0[j]) * blend;
    const auto steps = joints_to_steps(rig.model, q);
    EXPECT_NEAR(p.steps[0], steps[0], 1) << "point " << k;
    EXPECT_NEAR(p.steps[1], steps[1], 1) << "point " << k;
    EXPECT_NEAR(p.steps[2], steps[2], 1) << "point " << k;
    if (k == 0 || k == 59) {  // the ends exactly
      const auto end = joints_to_steps(rig.model, k == 0 ? q0 : q1);
      EXPECT_EQ(p.steps, (std::array<std::int32_t, 3>{end[0], end[1], end[2]}));
    }
    EXPECT_GE(p.dt_s, 0.001);
    if (p.grip_rad) {
      ++with_grip;
      EXPECT_NEAR(*p.grip_rad, deg_to_rad(rig.model.motors.gripper_closed_deg), 1e-3);
      EXPECT_GE(traj.samples[k].t_s, 0.3 - 1e-9);
    }
  }
  EXPECT_EQ(with_grip, 1);
}

// A calibrated dead band: the motor leads each joint by half the band in the direction it
// moves. Where a joint turns (here at the rest between going out and coming back, and at the
// start against the side it last moved to) the motors cross the band alone on a smooth ramp,
// so no point asks for more than the motors' acceleration; the last point leads the end by
// half the band on the side of the last motion. Checked against the points as sent.
TEST(Statements, LoadTrajectoryTakesUpACalibratedDeadBandWhereAJointTurns) {
  Rig rig;
  rig.model.calibration.backlash = {0.0, deg_to_rad(0.3), deg_to_rad(0.25)};
  ASSERT_TRUE(rig.up());
  rig.twin->set_directions({1, 1, 1});
  const JointVector q0{0.08, deg_to_rad(20), deg_to_rad(40), 0.0};
  const JointVector q1{0.08, deg_to_rad(10), deg_to_rad(30), 0.0};  // J2, J3 go down ...
  JointTrajectory traj = quintic(q0, q1, 3.0, 60);
  append(traj, quintic(q1, q0, 3.0, 60));  // ... and back up
  auto load = rig.twin->load_trajectory(traj);
  ASSERT_TRUE(load) << load.error().message;
  std::lock_guard lock(rig.device.m);
  const auto& pts = rig.device.received;
  ASSERT_EQ(static_cast<int>(pts.size()), load->points);
  EXPECT_GT(pts.size(), traj.samples.size());  // take-ups were inserted
  auto motor = [&](const JointVector& q, int d2, int d3) {
    // the joint map (docs/calibration.md): the firmware's joint = joint - band (homing_dir -
    // dir) / 2, the motor leading the joint by half the band on the side it moves
    const auto& hd = rig.model.endstops.homing_dir;
    JointVector m = q;
    m[1] -= 0.5 * (hd[1] - d2) * deg_to_rad(0.3);
    m[2] -= 0.5 * (hd[2] - d3) * deg_to_rad(0.25);
    // then the description's conversion, the J3 motor coupled to J2
    return std::array<double, 2>{
        m[1] * rig.model.motors.j2.steps_per_unit,
        m[2] * rig.model.motors.j3.steps_per_unit +
            rig.model.motors.j3_per_j2_coupling * m[1] * rig.model.motors.j2.steps_per_unit};
  };
  // starts where the motors are (leading upwards), ends leading upwards again
  const auto first = motor(q0, 1, 1);
  EXPECT_NEAR(pts.front().steps[1], first[0], 0.51);
  EXPECT_NEAR(pts.front().steps[2], first[1], 0.51);
  EXPECT_NEAR(pts.back().steps[1], first[0], 0.51);
  EXPECT_NEAR(pts.back().steps[2], first[1], 0.51);
  // at the turn, at rest at q1, the motors lead downwards
  const auto turned = motor(q1, -1, -1);
  bool at_turn = false;
  for (const auto& p : pts) {
    at_turn = at_turn || (std::abs(p.steps[1] - turned[0]) <= 0.51 &&
                          std::abs(p.steps[2] - turned[1]) <= 0.51);
  }
  EXPECT_TRUE(at_turn);
  // no jump: the acceleration between consecutive segments within the motors' limit
  const std::array<double, 2> limit{rig.model.motors.j2.max_accel_steps_s2,
                                    rig.model.motors.j3.max_accel_steps_s2};
  for (std::size_t k = 2; k < pts.size(); ++k) {
    for (int a = 1; a <= 2; ++a) {
      const double v1 = (pts[k - 1].steps[a] - pts[k - 2].steps[a]) / pts[k - 1].dt_s;
      const double v2 = (pts[k].steps[a] - pts[k - 1].steps[a]) / pts[k].dt_s;
      const double acc = std::abs(v2 - v1) / (0.5 * (pts[k - 1].dt_s + pts[k].dt_s));
      // one step of rounding in 20 ms shows as up to 2 / 0.02^2 steps/s^2 of apparent jitter
      EXPECT_LE(acc, limit[a - 1] + 2.0 / (pts[k].dt_s * pts[k].dt_s))
          << "point " << k << " axis " << a;
    }
  }
}

TEST(Statements, GripReleaseAndPicture) {
  Rig rig;
  ASSERT_TRUE(rig.up());
  auto g = rig.twin->grip();
  ASSERT_TRUE(g) << g.error().message;
  EXPECT_TRUE(g->virtual_closed);
  EXPECT_EQ(g->held_id, 7);
  auto r = rig.twin->release(Robots::kVirtual);
  ASSERT_TRUE(r);
  EXPECT_FALSE(r->virtual_closed);
  {
    std::lock_guard lock(rig.device.m);
    ASSERT_EQ(rig.device.grip_commands.size(), 1u);
    EXPECT_NEAR(rig.device.grip_commands[0], deg_to_rad(rig.model.motors.gripper_closed_deg), 1e-3);
  }

  std::vector<std::uint8_t> png{0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
  std::mt19937 rng(3);
  for (int i = 0; i < 200000; ++i) png.push_back(static_cast<std::uint8_t>(rng()));
  {
    std::lock_guard lock(rig.sim.m);
    rig.sim.png = png;
  }
  const auto path = std::filesystem::temp_directory_path() / "scaratwin-test-image.png";
  auto pic = rig.twin->take_picture(path);
  ASSERT_TRUE(pic) << pic.error().message;
  EXPECT_TRUE(*pic == png);
  std::ifstream f(path, std::ios::binary);
  std::vector<std::uint8_t> saved((std::istreambuf_iterator<char>(f)), {});
  EXPECT_TRUE(saved == png);
  std::filesystem::remove(path);

  auto refused = rig.twin->take_picture({}, 1, 1);  // the peer answers ER 15
  ASSERT_FALSE(refused);
  EXPECT_EQ(refused.error().code, protocol_error_code(protocol::core::kErrInternal));
  EXPECT_NE(refused.error().message.find("internal"), std::string::npos);
}

TEST(Statements, WithoutARobotTheStatementSaysSo) {
  RobotModel model = paper_robot();
  Twin twin(model, nullptr, nullptr);
  auto r = twin.read_physical_joints();
  ASSERT_FALSE(r);
  EXPECT_EQ(r.error().code, static_cast<int>(TransportError::kNotConnected));
  EXPECT_NE(r.error().message.find("physical"), std::string::npos);
  EXPECT_FALSE(twin.take_picture());
}

TEST(Channel, TimedOutRequestDoesNotShiftLaterReplies) {
  Rig rig;
  ASSERT_TRUE(rig.up());
  rig.sim.ignore_pings = true;
  auto lost = rig.simc->request(protocol::Ping{5}, Duration{100});
  ASSERT_FALSE(lost);
  EXPECT_EQ(lost.error().code, protocol_error_code(protocol::core::kErrTimeout));
  rig.sim.ignore_pings = false;
  auto hello = rig.simc->request(protocol::Hello{}, kWait);
  ASSERT_TRUE(hello) << hello.error().message;
  EXPECT_TRUE(std::holds_alternative<protocol::PeerHello>(hello->last()));
  auto ping = rig.simc->request(protocol::Ping{6}, kWait);
  ASSERT_TRUE(ping);
  const auto* ak = std::get_if<protocol::Ack>(&ping->last());
  ASSERT_NE(ak, nullptr);
  EXPECT_EQ(ak->value, 6);

  rig.device.ignore_queries = true;
  auto st = rig.robot->request(protocol::QueryState{}, Duration{100});
  ASSERT_FALSE(st);
  EXPECT_EQ(st.error().code, protocol_error_code(protocol::core::kErrTimeout));
}

TEST(Channel, PostedRequestGetsItsTimeoutWithoutFurtherTraffic) {
  Rig rig;
  ASSERT_TRUE(rig.up());
  rig.sim.ignore_pings = true;
  std::mutex m;
  std::vector<int> codes;
  const auto t0 = std::chrono::steady_clock::now();
  ASSERT_TRUE(rig.simc->post(
      protocol::Ping{9},
      [&](Result<SimChannel::Reply>&& r) {
        std::lock_guard lock(m);
        codes.push_back(r ? 0 : r.error().code);
      },
      Duration{100}));
  ASSERT_TRUE(eventually_size(m, codes, 1u));
  EXPECT_GE(std::chrono::steady_clock::now() - t0, std::chrono::milliseconds(100));
  std::lock_guard lock(m);
  EXPECT_EQ(codes[0], protocol_error_code(protocol::core::kErrTimeout));
}

TEST(Channel, AStateReportThatAnswersARequestReachesTheSubscriberToo) {
  Rig rig;
  ASSERT_TRUE(rig.up());
  std::mutex m;
  std::vector<std::uint16_t> seen;
  rig.robot->set_unsolicited_handler([&](protocol::SerialFromDevice&& msg, const RxPacket&) {
    std::lock_guard lock(m);
    if (const auto* st = std::get_if<protocol::DeviceState>(&msg)) seen.push_back(st->seq);
  });
  for (int i = 0; i < 3; ++i) {
    auto r = rig.robot->request(protocol::QueryState{}, kWait);
    ASSERT_TRUE(r) << r.error().message;
    const auto* st = std::get_if<protocol::DeviceState>(&r->last());
    ASSERT_NE(st, nullptr);
    ASSERT_TRUE(eventually_size(m, seen, static_cast<std::size_t>(i + 1)));
    std::lock_guard lock(m);
    EXPECT_EQ(seen.back(), st->seq) << "the reply and the subscriber saw different reports";
  }
  // and each report once
  std::this_thread::sleep_for(std::chrono::milliseconds(50));
  std::lock_guard lock(m);
  EXPECT_EQ(seen.size(), 3u);
}

TEST(Channel, DisconnectFailsPendingRequestsAndUnsolicitedPacketsArrive) {
  Rig rig;
  ASSERT_TRUE(rig.up());
  std::mutex m;
  std::vector<protocol::SerialFromDevice> events;
  rig.robot->set_unsolicited_handler([&](protocol::SerialFromDevice&& msg, const RxPacket&) {
    std::lock_guard lock(m);
    events.push_back(std::move(msg));
  });
  rig.device.send("EV=3=60=\nST=1=2=0=0=0=0=0=0=8=\nXX=\n");
  ASSERT_TRUE(eventually_size(m, events, 2u));
  {
    std::lock_guard lock(m);
    const auto* ev = std::get_if<protocol::DeviceEvent>(&events[0]);
    ASSERT_NE(ev, nullptr);
    EXPECT_EQ(ev->event, protocol::DeviceEventCode::kTrajectoryDone);
    EXPECT_TRUE(std::holds_alternative<protocol::DeviceState>(events[1]));
  }
  for (int i = 0; i < 200 && rig.robot->decode_errors() == 0; ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  EXPECT_EQ(rig.robot->decode_errors(), 1u);  // XX is not a code

  rig.sim.ignore_pings = true;
  std::thread dropper([&] {
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    rig.sim.drop();
  });
  const auto t0 = std::chrono::steady_clock::now();
  auto r = rig.simc->request(protocol::Ping{1}, Duration{10000});
  dropper.join();
  ASSERT_FALSE(r);
  EXPECT_EQ(r.error().code, protocol_error_code(protocol::core::kErrDisconnected));
  EXPECT_LT(std::chrono::steady_clock::now() - t0, std::chrono::seconds(5));
  // and the link comes back by itself
  rig.sim.ignore_pings = false;
  ASSERT_TRUE(rig.tcp->wait_connected(kWait));
  auto again = rig.simc->request(protocol::Ping{2}, kWait);
  ASSERT_TRUE(again) << again.error().message;
}

// The heartbeat: a peer that hangs with its connection open (a stopped simulator) answers
// nothing and sends no end of stream; the channel pings it, ends the connection once a
// request waited dead_after with nothing received, and the link reconnects; once the peer
// answers again the link stays up. Without the heartbeat (ChannelOptions default) the hung
// peer goes unnoticed: checked by hand with heartbeat 0 (the drop never comes).
ChannelOptions heartbeat_options() {
  ChannelOptions o;
  o.heartbeat = Duration{50};
  o.dead_after = Duration{300};
  return o;
}

TEST(Channel, HeartbeatEndsTheConnectionOfAHungPeerAndTheLinkComesBack) {
  Rig rig(heartbeat_options());
  ASSERT_TRUE(rig.up());
  std::mutex m;
  std::vector<LinkState> states;
  rig.simc->set_state_handler([&](LinkState s) {
    std::lock_guard lock(m);
    states.push_back(s);
  });
  // a healthy peer is pinged and never dropped (the pings counted, not timed: a busy machine
  // may run the channel's timer late)
  EXPECT_TRUE(eventually([&] { return rig.tcp->counters().packets_out >= 5; },
                         std::chrono::milliseconds(5000)))
      << "pings went out: " << rig.tcp->counters().packets_out;
  EXPECT_EQ(rig.simc->heartbeat_drops(), 0u);
  EXPECT_EQ(rig.tcp->counters().disconnects, 0u);

  rig.sim.hang = true;
  ASSERT_TRUE(eventually([&] { return rig.simc->heartbeat_drops() >= 1; },
                         std::chrono::milliseconds(5000)));
  EXPECT_NE(rig.simc->last_drop_reason().find("no reply to PI for "), std::string::npos)
      << rig.simc->last_drop_reason();
  // the channel counts the drop, then drops the link: the link's count and state follow (a
  // run in CI read the counter in between: 0 disconnects)
  EXPECT_TRUE(eventually([&] { return rig.tcp->counters().disconnects >= 1u; },
                         std::chrono::milliseconds(5000)))
      << "disconnects " << rig.tcp->counters().disconnects;
  EXPECT_TRUE(eventually(
      [&] {
        std::lock_guard lock(m);
        return std::find(states.begin(), states.end(), LinkState::kDisconnected) != states.end();
      },
      std::chrono::milliseconds(5000)));
  // a request sent to the hung peer fails as disconnected instead of waiting its timeout
  ASSERT_TRUE(rig.tcp->wait_connected(kWait));
  auto lost = rig.simc->request(protocol::Ping{3}, Duration{20000});
  ASSERT_FALSE(lost);
  EXPECT_EQ(lost.error().code, protocol_error_code(protocol::core::kErrDisconnected))
      << lost.error().message;

  // the peer resumes: it reads the connections the client gave up on from its backlog, then
  // the live one; the link comes back and stays up
  rig.sim.hang = false;
  ASSERT_TRUE(eventually(
      [&] { return static_cast<bool>(rig.simc->request(protocol::Ping{4}, Duration{200})); },
      std::chrono::milliseconds(10000)));
  const std::uint64_t drops = rig.simc->heartbeat_drops();
  std::this_thread::sleep_for(std::chrono::milliseconds(600));
  EXPECT_EQ(rig.simc->heartbeat_drops(), drops) << rig.simc->last_drop_reason();
  auto ping = rig.simc->request(protocol::Ping{5}, kWait);
  ASSERT_TRUE(ping) << ping.error().message;
}

// A camera shot blocks the peer (a render) longer than dead_after: as a slow code it may take
// its own timeout, and the connection stays; the same shot without the exemption ends it.
TEST(Channel, HeartbeatLetsASlowCodeTakeItsOwnTimeout) {
  for (const bool exempt : {true, false}) {
    ChannelOptions o = heartbeat_options();
    if (exempt) o.slow_codes = {"CS"};
    Rig rig(o);
    ASSERT_TRUE(rig.up());
    {
      std::lock_guard lock(rig.sim.m);
      rig.sim.png = {0x89, 'P', 'N', 'G'};
    }
    rig.sim.camera_ms = 900;
    auto shot = rig.simc->request(protocol::CameraShoot{640, 480}, Duration{5000});
    if (exempt) {
      ASSERT_TRUE(shot) << shot.error().message;
      EXPECT_TRUE(std::holds_alternative<protocol::Image>(shot->last()));
      EXPECT_EQ(rig.simc->heartbeat_drops(), 0u);
      EXPECT_EQ(rig.tcp->counters().disconnects, 0u);
    } else {
      ASSERT_FALSE(shot);
      EXPECT_EQ(shot.error().code, protocol_error_code(protocol::core::kErrDisconnected))
          << shot.error().message;
      EXPECT_NE(shot.error().message.find("no reply to CS for "), std::string::npos)
          << shot.error().message;
      EXPECT_EQ(rig.simc->heartbeat_drops(), 1u);
    }
  }
}

}  // namespace
}  // namespace scaratwin::transport
