// Test helper: one or more sample messages of every code of every link direction, and a
// random message generator (fixed seed) for round-trip and chunking tests.
#pragma once

#include <cmath>
#include <random>
#include <vector>

#include "scaratwin/core/units.hpp"
#include "scaratwin/protocol/messages.hpp"

namespace scaratwin::protocol::test {

// Values with at most 3 decimals in mm and 4 in degrees survive the wire exactly; mm() rounds
// the way the decoder does (one division of the decimal mantissa).
inline double mm(double v) { return std::round(v * 1000.0) / 1e6; }
inline double deg(double v) { return deg_to_rad(v); }

inline std::vector<SerialToDevice> serial_to_device_samples() {
  return {
      Hello{},
      Hello{1, {}, {}, "c6e454cc", std::nullopt},
      Ping{},
      Ping{42},
      SetReportRate{250},
      QueryState{},
      Home{},
      TrajectoryBegin{60},
      TrajectoryPoint{0, 0.5, {24600, -1200, 2000}, deg(45), std::nullopt},
      TrajectoryPoint{59, 0.1, {-2147483647 - 1, 2147483647, 0}, deg(0.01), deg(75)},
      SetGripper{deg(75)},
      Jog{Axis::kJ2, -150},
      Jog{Axis::kWrist, deg(12.5)},
      Stop{},
      Config{1, std::nullopt},
      Config{2, 1500},
      RealtimeCommand{Realtime::kStop},
      RealtimeCommand{Realtime::kHold},
      RealtimeCommand{Realtime::kResume},
  };
}

inline std::vector<SerialFromDevice> serial_from_device_samples() {
  return {
      PeerHello{1, "scara-uno", "0.1.0", {}},
      PeerHello{1, "scara-uno", "0.1.0", "c6e454cc"},
      DeviceState{65535,
                  4294967295u,
                  {24600, -1200, 2000},
                  deg(45),
                  deg(75),
                  state_flags::kHomed | state_flags::kMoving,
                  8},
      DeviceState{0, 0, {0, 0, 0}, 0, 0, 0, 0},
      Ack{"TP", 7},
      Ack{"SP", std::nullopt},
      ErrorReply{core::kErrQueueFull, 0},
      ErrorReply{core::kErrUnknownCode, std::nullopt},
      DeviceEvent{DeviceEventCode::kHomed, std::nullopt},
      DeviceEvent{DeviceEventCode::kTrajectoryDone, 60},
      DeviceEvent{DeviceEventCode::kHomingFailed, 1},
      DeviceEvent{static_cast<DeviceEventCode>(11), -40},
  };
}

inline std::vector<TcpToSim> tcp_to_sim_samples() {
  return {
      Hello{},
      Hello{1, "control", {}, "c6e454cc", std::nullopt},
      Hello{1, "observe", "s3cret", "0123abcd", std::nullopt},
      Hello{1, "control", {}, "c6e454cc", 1},
      Ping{7},
      JointData{17, 5000123, {mm(120), deg(12.5), deg(-30.25), deg(90)}},
      JointData{65535, 4294967295u, {mm(0.001), deg(-105), deg(204.9999), deg(0)}},
      JointTargets{3, 100, {mm(10), deg(0), deg(0), deg(180)}},
      SetMode{SimMode::kMirror},
      SetMode{SimMode::kSimulate},
      Grasp{true},
      Grasp{false},
      CameraShoot{},
      CameraShoot{320, 240},
      SpawnCube{CubeColor::kGreen, mm(150.5), mm(-20)},
      ResetScene{},
      QueryObjects{},
      QueryObjects{3},
      QueryState{},
      Stop{},
      SetTwinPhase{TwinPhase::kControl},
      SetTwinPhase{TwinPhase::kNone},
      JointData{18, 5000124, {mm(120), deg(12.5), deg(-30.25), deg(90)}, 1},
      QueryState{2},
      QueryContacts{},
  };
}

inline std::vector<TcpFromSim> tcp_from_sim_samples() {
  return {
      PeerHello{1, "scaratwin-sim", "0.1.0", {}},
      PeerHello{1, "scaratwin-sim", "0.1.0", "0badf00d"},
      JointApplied{17, 5000410},
      GripperState{true, 3},
      GripperState{false, -1},
      Image{{0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'}},
      Image{},
      ObjectPose{3, CubeColor::kBlue, mm(150.5), mm(-20), mm(-30), deg(12.25)},
      SimState{9, 2000000, {mm(120), deg(1), deg(2), deg(3)}, true, 3, SimMode::kSimulate},
      JointWarning{1, mm(120)},
      JointWarning{3, deg(205)},
      JointWarning{2, deg(130), 1},
      JointApplied{19, 5000500, 1},
      Ack{"SC", 3},
      Ack{"RS", std::nullopt},
      ErrorReply{core::kErrBadValue, 0},
      ArmContacts{},
      ArmContacts{3, 0, 1, 1500000},
  };
}

// Random messages drawn from the samples with randomized numeric fields.
template <typename Direction>
std::vector<Direction> random_stream(const std::vector<Direction>& samples, std::mt19937& rng,
                                     std::size_t count) {
  std::uniform_int_distribution<std::size_t> pick(0, samples.size() - 1);
  std::uniform_int_distribution<int> seq(0, 65535);
  std::uniform_int_distribution<int> milli(-200000, 200000);
  std::vector<Direction> out;
  out.reserve(count);
  for (std::size_t i = 0; i < count; ++i) {
    Direction m = samples[pick(rng)];
    std::visit(
        [&](auto& v) {
          using T = std::decay_t<decltype(v)>;
          if constexpr (std::is_same_v<T, JointData> || std::is_same_v<T, JointTargets>) {
            v.seq = static_cast<std::uint16_t>(seq(rng));
            v.q = {mm(milli(rng) / 1000.0), deg(milli(rng) / 1000.0), deg(milli(rng) / 1000.0),
                   deg(milli(rng) / 1000.0)};
          } else if constexpr (std::is_same_v<T, DeviceState>) {
            v.seq = static_cast<std::uint16_t>(seq(rng));
            v.steps = {milli(rng), milli(rng), milli(rng)};
          } else if constexpr (std::is_same_v<T, Image>) {
            v.png.resize(static_cast<std::size_t>(seq(rng) % 300));
            for (auto& b : v.png) b = static_cast<std::uint8_t>(rng());
          }
        },
        m);
    out.push_back(std::move(m));
  }
  return out;
}

}  // namespace scaratwin::protocol::test
