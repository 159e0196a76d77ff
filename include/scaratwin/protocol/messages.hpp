// Typed protocol messages (docs/protocol.md), one struct per code and direction, in SI units.
//
// The wire carries mm, degrees, centidegrees and milliseconds; these structs carry metres,
// radians and seconds, converted at the encode/decode edge in one place
// (src/protocol/wire_units.hpp). Two kinds of values keep their wire unit on purpose:
// motor positions in steps (converting them to joints needs the robot description:
// kinematics/motor.hpp) and timestamps in wrapping microseconds (`t_us`, modulo 2^32, exact).
//
// Each packet struct is its row of the protocol's code table (fields.hpp): its code, the reply
// that answers it, and its fields in wire order with their units and accepted values. The four
// direction variants (SerialToDevice, SerialFromDevice, TcpToSim, TcpFromSim) list what each
// receiver can get, in the order of docs/protocol.md's tables; codec.hpp encodes and decodes
// them, replies.hpp matches replies to requests, all from these rows.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <tuple>
#include <variant>
#include <vector>

#include "scaratwin/core/robot_types.hpp"
#include "scaratwin/protocol/codec_core.h"
#include "scaratwin/protocol/fields.hpp"

namespace scaratwin::protocol {

using core::kErrAccess;
using core::kErrNoRobot;
using core::kMaxRobotIndex;
using core::kProtocolVersion;
using ErrorCode = core::ErrorCode;

// --- shared by both links -----------------------------------------------------------------

// HI request (hub -> simulator, host -> device). On the simulator link a hello may say who
// is connecting: `role` "control" (the default when empty) or "observe" (queries only), and
// the simulator's access token when it asks for one (docs/security.md). Both are empty on
// the serial link. `description`: the hash of the robot description the hub runs on (8
// lower-case hex digits, kinematics/robot_model.hpp description_hash()), or empty (a v1
// hello); a peer answers a hello that carries one with its own (docs/protocol.md section 11).
// `robot` (simulator link, after the description): the one robot of the simulator's workcell
// a controlling hub drives; none: it controls the whole simulator (docs/security.md).
struct Hello {
  std::int32_t version = kProtocolVersion;
  std::string role;                   // "", "control" or "observe"
  std::string token;                  // "" or [A-Za-z0-9_.-]{1,32}
  std::string description;            // "" or 8 lower-case hex digits
  std::optional<std::int32_t> robot;  // 0..255, TCP only, only with a description

  friend bool operator==(const Hello&, const Hello&) = default;

  static constexpr std::string_view kCode = "HI";
  static constexpr field::Reply kReply{"HI"};
  static constexpr auto fields() {
    using S = Hello;
    return std::tuple{field::i32(&S::version), field::HelloAccess{},
                      field::description(&S::description), field::HelloRobot{}};
  }
};
// HI reply (simulator -> hub, device -> host).
// `description`: the hash of the robot description the peer was built for or started with,
// sent only in answer to a hello that carried the hub's; empty from a v1 peer.
struct PeerHello {
  std::int32_t version = kProtocolVersion;
  std::string device;            // [A-Za-z0-9_.-]{1,32}, e.g. "scara-uno", "scaratwin-sim"
  std::string software_version;  // same alphabet, e.g. "0.1.0"
  std::string description;       // "" or 8 lower-case hex digits

  friend bool operator==(const PeerHello&, const PeerHello&) = default;

  static constexpr std::string_view kCode = "HI";
  static constexpr auto fields() {
    using S = PeerHello;
    return std::tuple{field::i32(&S::version), field::text(&S::device, "device"),
                      field::text(&S::software_version, "software_version"),
                      field::description(&S::description)};
  }
};
// PI: ping; the reply is Ack{"PI", token}.
struct Ping {
  std::optional<std::int32_t> token;

  friend bool operator==(const Ping&, const Ping&) = default;

  static constexpr std::string_view kCode = "PI";
  static constexpr auto fields() {
    using S = Ping;
    return std::tuple{field::opt_i32(&S::token)};
  }
};
// QS: query one state report (DeviceState on serial, SimState on TCP). `robot` on TCP only.
struct QueryState {
  std::int32_t robot = 0;  // robot index (protocol v2, docs/protocol.md section 11.3)
  friend bool operator==(const QueryState&, const QueryState&) = default;

  static constexpr std::string_view kCode = "QS";
  static constexpr field::Reply kReply{"ST"};
  static constexpr auto fields() {
    using S = QueryState;
    return std::tuple{field::robot(&S::robot)};
  }
};
// SP: stop. Serial: clear the queue and decelerate; TCP: hold the current joints. `robot` on
// TCP only.
struct Stop {
  std::int32_t robot = 0;  // robot index (protocol v2, docs/protocol.md section 11.3)
  friend bool operator==(const Stop&, const Stop&) = default;

  static constexpr std::string_view kCode = "SP";
  static constexpr auto fields() {
    using S = Stop;
    return std::tuple{field::robot(&S::robot)};
  }
};
// AK: the request with `code` (two upper-case letters) was done; `value` per code.
struct Ack {
  std::string code;
  std::optional<std::int32_t> value;

  friend bool operator==(const Ack&, const Ack&) = default;

  static constexpr std::string_view kCode = "AK";
  static constexpr auto fields() {
    using S = Ack;
    return std::tuple{field::code_text(&S::code, "code"), field::opt_i32(&S::value)};
  }
};
// ER: refused or not understood. `code` is an ErrorCode (docs/protocol.md section 6).
struct ErrorReply {
  std::int32_t code = core::kErrInternal;
  std::optional<std::int32_t> detail;

  friend bool operator==(const ErrorReply&, const ErrorReply&) = default;

  static constexpr std::string_view kCode = "ER";
  static constexpr auto fields() {
    using S = ErrorReply;
    return std::tuple{field::i32(&S::code, 1, 255), field::opt_i32(&S::detail)};
  }
};

// --- physical link (serial): host -> device ------------------------------------------------

// Motors counted in steps from the joint zero: Z, J2, J3 (J3 includes the belt coupling).
using MotorSteps = std::array<std::int32_t, 3>;

// SR: periodic DeviceState reports, 0 = off, 1..1000 Hz.
struct SetReportRate {
  std::int32_t rate_hz = 0;

  friend bool operator==(const SetReportRate&, const SetReportRate&) = default;

  static constexpr std::string_view kCode = "SR";
  static constexpr auto fields() {
    using S = SetReportRate;
    return std::tuple{field::i32(&S::rate_hz, 0, 1000)};
  }
};
// HM: home Z, J2, J3 against their endstops.
struct Home {
  friend bool operator==(const Home&, const Home&) = default;

  static constexpr std::string_view kCode = "HM";
  static constexpr auto fields() { return std::tuple{}; }
};
// TB: begin a trajectory of `points` (1..65535) TrajectoryPoint packets.
struct TrajectoryBegin {
  std::int32_t points = 0;

  friend bool operator==(const TrajectoryBegin&, const TrajectoryBegin&) = default;

  static constexpr std::string_view kCode = "TB";
  static constexpr auto fields() {
    using S = TrajectoryBegin;
    return std::tuple{field::i32(&S::points, 1, 65535)};
  }
};
// TP: one timed point: absolute motor targets reached `dt_s` after the previous point
// (1 ms .. 65.535 s, sent in whole ms); wrist and optional gripper servo angles in rad
// (0..pi, sent in centidegrees).
struct TrajectoryPoint {
  std::int32_t seq = 0;  // 0..points-1
  double dt_s = 0.0;
  MotorSteps steps{};
  double wrist_rad = 0.0;
  std::optional<double> grip_rad;

  friend bool operator==(const TrajectoryPoint&, const TrajectoryPoint&) = default;

  static constexpr std::string_view kCode = "TP";
  static constexpr auto fields() {
    using S = TrajectoryPoint;
    return std::tuple{field::i32(&S::seq, 0, 65534), field::millis(&S::dt_s, "dt_s", 1, 65535),
                      field::steps(&S::steps), field::cdeg(&S::wrist_rad, "wrist_rad", 0, 18000),
                      field::opt_cdeg(&S::grip_rad, "grip_rad", 0, 18000)};
  }
};
// GR on serial: gripper servo angle in rad (0..pi).
struct SetGripper {
  double angle_rad = 0.0;

  friend bool operator==(const SetGripper&, const SetGripper&) = default;

  static constexpr std::string_view kCode = "GR";
  static constexpr auto fields() {
    using S = SetGripper;
    return std::tuple{field::cdeg(&S::angle_rad, "angle_rad", 0, 18000)};
  }
};
enum class Axis : std::int32_t { kZ = 0, kJ2 = 1, kJ3 = 2, kWrist = 3 };
// JG: jog one motor relative: `delta` in steps for Z/J2/J3, in rad for the wrist.
struct Jog {
  Axis axis = Axis::kZ;
  double delta = 0.0;

  friend bool operator==(const Jog&, const Jog&) = default;

  static constexpr std::string_view kCode = "JG";
  static constexpr auto fields() {
    using S = Jog;
    return std::tuple{field::int_enum(&S::axis, 0, 3), field::JogDelta{}};
  }
};
// CF: read (`value` empty) or write a setting (keys in docs/protocol.md section 8).
struct Config {
  std::int32_t key = 0;
  std::optional<std::int32_t> value;

  friend bool operator==(const Config&, const Config&) = default;

  static constexpr std::string_view kCode = "CF";
  // the firmware's keys 1..11 (docs/firmware.md); their values are the firmware's to judge
  static constexpr auto fields() {
    using S = Config;
    return std::tuple{field::i32(&S::key, 1, 11), field::opt_i32(&S::value)};
  }
};
// A real-time byte ('!', '#', '~'), acted on at once by the device, even mid-line.
enum class Realtime : char { kStop = '!', kHold = '#', kResume = '~' };
struct RealtimeCommand {
  Realtime command = Realtime::kStop;

  friend bool operator==(const RealtimeCommand&, const RealtimeCommand&) = default;
};

// --- physical link (serial): device -> host ------------------------------------------------

// Bits of DeviceState::flags.
namespace state_flags {
inline constexpr std::uint32_t kHomed = 1, kMoving = 2, kTrajectory = 4, kHold = 8, kHalted = 16,
                               kEndstopZ = 32, kEndstopJ2 = 64, kEndstopJ3 = 128;
}  // namespace state_flags

// ST from the device: the ACTUAL step counters and servo outputs.
struct DeviceState {
  std::uint16_t seq = 0;   // wraps at 65536
  std::uint32_t t_us = 0;  // device clock, micros(), wraps at 2^32
  MotorSteps steps{};
  double wrist_rad = 0.0;
  double grip_rad = 0.0;
  std::uint32_t flags = 0;      // state_flags
  std::int32_t queue_free = 0;  // free trajectory slots (flow-control credit)

  friend bool operator==(const DeviceState&, const DeviceState&) = default;

  static constexpr std::string_view kCode = "ST";
  static constexpr auto fields() {
    using S = DeviceState;
    return std::tuple{field::i32(&S::seq, 0, 65535),
                      field::u32(&S::t_us),
                      field::steps(&S::steps),
                      field::cdeg(&S::wrist_rad, "wrist_rad"),
                      field::cdeg(&S::grip_rad, "grip_rad"),
                      field::i32(&S::flags, 0, 0x7fffffff),
                      field::i32(&S::queue_free, 0, 65535)};
  }
};
enum class DeviceEventCode : std::int32_t {
  kHomed = 1,
  kEndstop = 2,         // value: axis
  kTrajectoryDone = 3,  // value: points run
  kJogButton = 4,       // value: button
  kUnderrun = 5,        // value: next expected seq
  kStopped = 6,
  kHeld = 7,
  kResumed = 8,
  kHomingFailed = 9,    // value: axis
  kHomingOffsetZ = 10,  // 11 J2, 12 J3; value: count - switch position when homing again (steps)
};
inline constexpr int kLastDeviceEvent = 12;
// EV: unsolicited device event.
struct DeviceEvent {
  DeviceEventCode event = DeviceEventCode::kHomed;
  std::optional<std::int32_t> value;

  friend bool operator==(const DeviceEvent&, const DeviceEvent&) = default;

  static constexpr std::string_view kCode = "EV";
  static constexpr auto fields() {
    using S = DeviceEvent;
    return std::tuple{field::int_enum(&S::event, 1, kLastDeviceEvent), field::opt_i32(&S::value)};
  }
};

// --- virtual link (TCP): hub -> simulator --------------------------------------------------

// JD: joint data for the mirror mode. `q`: d1 (m), q2, q3, q4 (rad), DH order.
struct JointData {
  std::uint16_t seq = 0;   // the device's ST seq when mirroring
  std::uint32_t t_us = 0;  // sample time in the hub's clock, wraps at 2^32
  JointVector q{};
  std::int32_t robot = 0;  // robot index (protocol v2, docs/protocol.md section 11.3)

  friend bool operator==(const JointData&, const JointData&) = default;

  static constexpr std::string_view kCode = "JD";
  static constexpr field::Reply kReply{"JA", false, true};
  static constexpr auto fields() {
    using S = JointData;
    return std::tuple{field::i32(&S::seq, 0, 65535), field::u32(&S::t_us), field::joints(&S::q),
                      field::robot(&S::robot)};
  }
};
// TJ: joint targets for the simulate mode (position actuators). Same fields as JointData.
struct JointTargets {
  std::uint16_t seq = 0;
  std::uint32_t t_us = 0;
  JointVector q{};
  std::int32_t robot = 0;  // robot index (protocol v2, docs/protocol.md section 11.3)

  friend bool operator==(const JointTargets&, const JointTargets&) = default;

  static constexpr std::string_view kCode = "TJ";
  static constexpr field::Reply kReply{"JA", false, true};
  static constexpr auto fields() {
    using S = JointTargets;
    return std::tuple{field::i32(&S::seq, 0, 65535), field::u32(&S::t_us), field::joints(&S::q),
                      field::robot(&S::robot)};
  }
};
enum class SimMode { kMirror, kSimulate };
// "mirror", "simulate"
constexpr const char* mode_name(SimMode mode) {
  return mode == SimMode::kMirror ? "mirror" : "simulate";
}
// MD: switch the simulator's mode.
struct SetMode {
  SimMode mode = SimMode::kMirror;
  std::int32_t robot = 0;  // robot index (protocol v2, docs/protocol.md section 11.3)

  friend bool operator==(const SetMode&, const SetMode&) = default;

  static constexpr std::string_view kCode = "MD";
  static constexpr auto fields() {
    using S = SetMode;
    return std::tuple{field::name_enum(&S::mode, mode_name, 2, "mode"), field::robot(&S::robot)};
  }
};
// The paper's three operating modes of the twin, as the hub runs them; none: the hub says
// nothing (the UI derives what it shows from the simulator's mode).
// kHoming: the robot homes against its endstops, passing its soft limits on the way (the
// simulator notes no limit warning meanwhile).
enum class TwinPhase { kNone, kMirror, kControl, kPrediction, kHoming };
// "none", "mirror", "control", "prediction", "homing"
constexpr const char* phase_name(TwinPhase phase) {
  switch (phase) {
    case TwinPhase::kMirror:
      return "mirror";
    case TwinPhase::kControl:
      return "control";
    case TwinPhase::kPrediction:
      return "prediction";
    case TwinPhase::kHoming:
      return "homing";
    case TwinPhase::kNone:
      break;
  }
  return "none";
}
// TW: what the twin is doing, for the simulator's browser UI.
struct SetTwinPhase {
  TwinPhase phase = TwinPhase::kNone;
  std::int32_t robot = 0;  // robot index (protocol v2, docs/protocol.md section 11.3)

  friend bool operator==(const SetTwinPhase&, const SetTwinPhase&) = default;

  static constexpr std::string_view kCode = "TW";
  static constexpr auto fields() {
    using S = SetTwinPhase;
    return std::tuple{field::name_enum(&S::phase, phase_name, 5, "phase"), field::robot(&S::robot)};
  }
};
// GR on TCP: grasp (true) or release (false).
struct Grasp {
  bool close = false;
  std::int32_t robot = 0;  // robot index (protocol v2, docs/protocol.md section 11.3)

  friend bool operator==(const Grasp&, const Grasp&) = default;

  static constexpr std::string_view kCode = "GR";
  static constexpr field::Reply kReply{"GR"};
  static constexpr auto fields() {
    using S = Grasp;
    return std::tuple{field::flag(&S::close), field::robot(&S::robot)};
  }
};
// CS: camera shoot; 0 x 0 means the size in the robot description.
struct CameraShoot {
  std::int32_t width_px = 0;
  std::int32_t height_px = 0;

  friend bool operator==(const CameraShoot&, const CameraShoot&) = default;

  static constexpr std::string_view kCode = "CS";
  static constexpr field::Reply kReply{"IM"};
  static constexpr auto fields() { return std::tuple{field::ShotSize{}}; }
};
// SC: spawn a cube on the table at (x, y) in the robot base frame, metres.
struct SpawnCube {
  CubeColor color = CubeColor::kRed;
  double x_m = 0.0;
  double y_m = 0.0;

  friend bool operator==(const SpawnCube&, const SpawnCube&) = default;

  static constexpr std::string_view kCode = "SC";
  static constexpr auto fields() {
    using S = SpawnCube;
    return std::tuple{field::name_enum(&S::color, color_name, kNumColors, "color"),
                      field::length_mm(&S::x_m, "x_m"), field::length_mm(&S::y_m, "y_m")};
  }
};
// RS: reset the scene (cubes removed, joints home).
struct ResetScene {
  friend bool operator==(const ResetScene&, const ResetScene&) = default;

  static constexpr std::string_view kCode = "RS";
  static constexpr auto fields() { return std::tuple{}; }
};
// OP request: the poses of all objects, or of one id.
struct QueryObjects {
  std::optional<std::int32_t> id;

  friend bool operator==(const QueryObjects&, const QueryObjects&) = default;

  static constexpr std::string_view kCode = "OP";
  static constexpr field::Reply kReply{"OP", true};
  static constexpr auto fields() {
    using S = QueryObjects;
    return std::tuple{field::opt_i32(&S::id)};
  }
};

// --- virtual link (TCP): simulator -> hub --------------------------------------------------

// JA: the JD/TJ with `seq` was applied at `t_apply_us` (simulator clock, wraps at 2^32).
struct JointApplied {
  std::uint16_t seq = 0;
  std::uint32_t t_apply_us = 0;
  std::int32_t robot = 0;  // robot index (protocol v2, docs/protocol.md section 11.3)

  friend bool operator==(const JointApplied&, const JointApplied&) = default;

  static constexpr std::string_view kCode = "JA";
  static constexpr auto fields() {
    using S = JointApplied;
    return std::tuple{field::i32(&S::seq, 0, 65535), field::u32(&S::t_apply_us),
                      field::robot(&S::robot)};
  }
};
// GR reply: gripper closed or open, and the held object id (-1: none).
struct GripperState {
  bool closed = false;
  std::int32_t held_id = -1;
  std::int32_t robot = 0;  // robot index (protocol v2, docs/protocol.md section 11.3)

  friend bool operator==(const GripperState&, const GripperState&) = default;

  static constexpr std::string_view kCode = "GR";
  static constexpr auto fields() {
    using S = GripperState;
    return std::tuple{field::flag(&S::closed), field::i32(&S::held_id, -1, 0x7fffffff),
                      field::robot(&S::robot)};
  }
};
// IM: a camera image as PNG bytes (at most core::kMaxImageBytes).
struct Image {
  std::vector<std::uint8_t> png;

  friend bool operator==(const Image&, const Image&) = default;

  static constexpr std::string_view kCode = "IM";
  static constexpr auto fields() { return std::tuple{field::PayloadSize{}}; }
};
// OP reply: one object's pose in the robot base frame (m, rad).
struct ObjectPose {
  std::int32_t id = 0;
  CubeColor color = CubeColor::kRed;
  double x_m = 0.0;
  double y_m = 0.0;
  double z_m = 0.0;
  double yaw_rad = 0.0;

  friend bool operator==(const ObjectPose&, const ObjectPose&) = default;

  static constexpr std::string_view kCode = "OP";
  static constexpr auto fields() {
    using S = ObjectPose;
    return std::tuple{field::i32(&S::id),
                      field::name_enum(&S::color, color_name, kNumColors, "color"),
                      field::length_mm(&S::x_m, "x_m"),
                      field::length_mm(&S::y_m, "y_m"),
                      field::length_mm(&S::z_m, "z_m"),
                      field::angle_deg(&S::yaw_rad, "yaw_rad")};
  }
};
// ST from the simulator.
struct SimState {
  std::uint16_t seq = 0;
  std::uint32_t t_us = 0;  // simulation time, wraps at 2^32
  JointVector q{};
  bool grip_closed = false;
  std::int32_t held_id = -1;
  SimMode mode = SimMode::kMirror;
  std::int32_t robot = 0;  // robot index (protocol v2, docs/protocol.md section 11.3)

  friend bool operator==(const SimState&, const SimState&) = default;

  static constexpr std::string_view kCode = "ST";
  static constexpr auto fields() {
    using S = SimState;
    return std::tuple{field::i32(&S::seq, 0, 65535),
                      field::u32(&S::t_us),
                      field::joints(&S::q),
                      field::flag(&S::grip_closed),
                      field::i32(&S::held_id, -1, 0x7fffffff),
                      field::name_enum(&S::mode, mode_name, 2, "mode"),
                      field::robot(&S::robot)};
  }
};
// JW: a commanded joint was clamped at its limit. joint 1..4; value in m (joint 1) or rad.
struct JointWarning {
  std::int32_t joint = 1;
  double value = 0.0;
  std::int32_t robot = 0;  // robot index (protocol v2, docs/protocol.md section 11.3)

  friend bool operator==(const JointWarning&, const JointWarning&) = default;

  static constexpr std::string_view kCode = "JW";
  static constexpr auto fields() {
    using S = JointWarning;
    return std::tuple{field::i32(&S::joint, 1, 4), field::WarningValue{}, field::robot(&S::robot)};
  }
};

// AC request: the contacts between the arms of the simulator's workcell so far.
struct QueryContacts {
  friend bool operator==(const QueryContacts&, const QueryContacts&) = default;

  static constexpr std::string_view kCode = "AC";
  static constexpr field::Reply kReply{"AC"};
  static constexpr auto fields() { return std::tuple{}; }
};
// AC reply: how many times two arms have touched since the simulator started (a touch counts
// once however long it lasts), and the last one's two robots (-1: none yet) and simulation
// time.
struct ArmContacts {
  std::int32_t count = 0;
  std::int32_t robot_a = -1;
  std::int32_t robot_b = -1;
  std::uint32_t t_us = 0;

  friend bool operator==(const ArmContacts&, const ArmContacts&) = default;

  static constexpr std::string_view kCode = "AC";
  static constexpr auto fields() {
    using S = ArmContacts;
    return std::tuple{field::i32(&S::count, 0, 0x7fffffff), field::i32(&S::robot_a, -1, 255),
                      field::i32(&S::robot_b, -1, 255), field::u32(&S::t_us)};
  }
};

// --- what each receiver gets ---------------------------------------------------------------

using SerialToDevice =
    std::variant<Hello, Ping, SetReportRate, QueryState, Home, TrajectoryBegin, TrajectoryPoint,
                 SetGripper, Jog, Stop, Config, RealtimeCommand>;
using SerialFromDevice = std::variant<PeerHello, DeviceState, Ack, ErrorReply, DeviceEvent>;
using TcpToSim =
    std::variant<Hello, Ping, JointData, JointTargets, SetMode, Grasp, CameraShoot, SpawnCube,
                 ResetScene, QueryObjects, QueryState, Stop, SetTwinPhase, QueryContacts>;
using TcpFromSim = std::variant<PeerHello, JointApplied, GripperState, Image, ObjectPose, SimState,
                                JointWarning, ArmContacts, Ack, ErrorReply>;

}  // namespace scaratwin::protocol
