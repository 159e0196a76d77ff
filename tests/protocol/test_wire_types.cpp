// The wire message types stand on their own: messages.hpp and codec.hpp build without the
// kinematics library. This file declares a RobotModel of its own; were the robot description
// (kinematics/robot_model.hpp) pulled in through the protocol headers, it would not compile.
#include <gtest/gtest.h>

#include "scaratwin/protocol/codec.hpp"
#include "scaratwin/protocol/messages.hpp"

namespace scaratwin {

struct RobotModel {
  int not_the_description = 0;
};

namespace {

TEST(WireTypes, EncodeAndDecodeWithoutTheRobotDescription) {
  const RobotModel unrelated;
  EXPECT_EQ(unrelated.not_the_description, 0);
  const protocol::TcpToSim m = protocol::SpawnCube{CubeColor::kGreen, 0.2, -0.05};
  const auto line = protocol::encode(m);
  ASSERT_TRUE(line.ok()) << line.error().message;
  EXPECT_EQ(*line, "SC,green,200,-50,\n");
  protocol::TcpToSimDecoder d;
  const auto items = d.feed(*line);
  ASSERT_EQ(items.size(), 1u);
  EXPECT_EQ(std::get<0>(items[0]), m);
}

}  // namespace
}  // namespace scaratwin
