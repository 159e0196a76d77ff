// The control statements against the real simulator (SimServer over loopback TCP): the
// channel's reply matching and the statements' decoding must agree with the simulator's end
// of the protocol, not only with the small peers of test_statements.
#include <utility>

#include <gtest/gtest.h>

#include "scaratwin/config/robot_config.hpp"
#include "scaratwin/core/units.hpp"
#include "scaratwin/sim/server.hpp"
#include "scaratwin/sim/world.hpp"
#include "scaratwin/transport/statements.hpp"
#include "scaratwin/transport/tcp.hpp"

namespace scaratwin::transport {
namespace {

constexpr Duration kWait{5000};

TEST(TwinWithSimulator, StatementsAgainstTheRealSimulator) {
  auto model = load_robot_config(SCARATWIN_CONFIG_FILE);
  ASSERT_TRUE(model) << model.error().message;
  auto world = sim::World::create(*model);
  ASSERT_TRUE(world) << world.error().message;
  sim::ServerOptions so;
  so.port = 0;
  auto server = sim::SimServer::create(**world, so);
  ASSERT_TRUE(server) << server.error().message;
  TcpClientOptions co;
  co.port = (*server)->port();
  auto client = TcpClient::create(co);
  ASSERT_TRUE(client);
  ASSERT_TRUE((*client)->wait_connected(kWait));
  SimChannel channel(**client);
  TwinOptions to;
  to.reply_timeout = kWait;
  Twin twin(*model, nullptr, &channel, to);

  auto hello = channel.request(protocol::Hello{}, kWait);
  ASSERT_TRUE(hello) << hello.error().message;
  ASSERT_TRUE(std::holds_alternative<protocol::PeerHello>(hello->last()));

  // func_data
  const JointVector q{0.1, deg_to_rad(20), deg_to_rad(-40), deg_to_rad(30)};
  for (int i = 0; i < 5; ++i) {
    auto applied = twin.send_joints_to_virtual(q);
    ASSERT_TRUE(applied) << applied.error().message;
    EXPECT_EQ(applied->seq, i);
    EXPECT_GE(applied->latency_us, 0);  // one machine: the same steady clock
  }

  // func_point: a spawned cube, found again at its position
  auto spawn = channel.request(protocol::SpawnCube{CubeColor::kGreen, 0.16, 0.04}, kWait);
  ASSERT_TRUE(spawn) << spawn.error().message;
  const auto* ak = std::get_if<protocol::Ack>(&spawn->last());
  ASSERT_NE(ak, nullptr);
  ASSERT_TRUE(ak->value.has_value());
  auto pose = twin.object_position(*ak->value);
  ASSERT_TRUE(pose) << pose.error().message;
  EXPECT_EQ(pose->color, CubeColor::kGreen);
  EXPECT_NEAR(pose->x_m, 0.16, 0.005);
  EXPECT_NEAR(pose->y_m, 0.04, 0.005);
  auto all = twin.object_positions();
  ASSERT_TRUE(all) << all.error().message;
  EXPECT_GE(all->size(), 1u);
  auto none = twin.object_position(9999);
  EXPECT_FALSE(none);

  // gripper and camera
  auto grip = twin.grip(Robots::kVirtual);
  ASSERT_TRUE(grip) << grip.error().message;
  EXPECT_TRUE(grip->virtual_closed);
  auto release = twin.release(Robots::kVirtual);
  ASSERT_TRUE(release) << release.error().message;
  EXPECT_FALSE(release->virtual_closed);
  auto png = twin.take_picture({}, 160, 120);
  ASSERT_TRUE(png) << png.error().message;
  ASSERT_GT(png->size(), 8u);
  const std::uint8_t signature[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
  EXPECT_TRUE(std::equal(signature, signature + 8, png->begin()));

  EXPECT_EQ(channel.decode_errors(), 0u) << channel.last_decode_error();
  EXPECT_EQ((*client)->counters().errors, 0u);
}

}  // namespace
}  // namespace scaratwin::transport
