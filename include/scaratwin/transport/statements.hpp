// The control statements (the paper's control-statement set), one call each. A Twin holds the
// channel to the physical robot (serial firmware) and the channel to the virtual robot (the
// simulator over TCP) plus the robot description, and hides addressing, encoding, unit
// conversion and waiting for replies. Every call returns a Result: the peer's refusal (its ER
// code), kErrTimeout (16), kErrDisconnected (17), or a TransportError / kErrBadValue for a
// local problem, each with a message naming the statement. A protocol code N is the
// Error::code protocol_error_code(N) = 200 + N (scaratwin/core/error_codes.hpp).
//
//   paper                 here
//   OperationMonitoring2  read_physical_joints()   QS -> ST, steps -> joints, stored
//   func_data             send_joints_to_virtual() JD -> JA (apply latency)
//   func_point            object_position(id)      OP id -> OP, AK
//   numberTran3           load_trajectory()        TB, TP... with credit flow control
//   (gripper)             grip(), release()        GR on either or both robots
//   (camera)              take_picture()           CS -> IM, PNG bytes, optionally saved
//
// Statements are blocking and meant for one caller thread (a script, the hub's sequencer);
// the channels underneath are thread-safe.
#pragma once

#include <cstdint>
#include <filesystem>
#include <mutex>
#include <vector>

#include "scaratwin/core/result.hpp"
#include "scaratwin/kinematics/motor.hpp"
#include "scaratwin/kinematics/robot_model.hpp"
#include "scaratwin/trajectory/trajectory.hpp"
#include "scaratwin/transport/channel.hpp"

namespace scaratwin::transport {

struct TwinOptions {
  Duration reply_timeout{1000};     // one request/reply
  Duration image_timeout{10000};    // camera shot: render + PNG encode + transfer
  Duration credit_poll{20};         // trajectory: how often to ask for free slots when out
  std::size_t max_stored = 100000;  // joint samples kept by read_physical_joints()
  // the virtual robot's index in the simulator's workcell: every robot-addressed packet to
  // the simulator carries it (protocol v2, docs/protocol.md section 11.3; 0: the first robot,
  // whose packets keep their v1 bytes)
  std::int32_t robot = 0;
};

// One stored reading of the physical robot (OperationMonitoring2).
struct PhysicalJoints {
  JointVector q{};                // d1 (m), q2, q3, q4 (rad) from the ACTUAL step counters
  double grip_rad = 0.0;          // gripper servo angle
  std::uint16_t seq = 0;          // device state sequence number
  std::uint32_t device_t_us = 0;  // device clock (wraps at 2^32)
  std::uint32_t flags = 0;        // protocol::state_flags
  std::int32_t queue_free = 0;
  std::int64_t rx_steady_us = 0;  // hub receive time (steady clock)
  std::int64_t rx_system_us = 0;  // hub receive time (system clock, Unix epoch)
};

// func_data's outcome: the JD sent and when the simulator applied it.
struct JointsApplied {
  std::uint16_t seq = 0;
  std::uint32_t sent_t_us = 0;     // JD t_us: steady clock of the hub, mod 2^32
  std::uint32_t apply_t_us = 0;    // JA t_apply_us: simulator clock (same clock on one machine)
  std::int64_t latency_us = 0;     // apply - sent, modulo 2^32, as a signed difference
  std::int64_t round_trip_us = 0;  // hub send -> JA received
};

// numberTran3's outcome.
struct TrajectoryLoad {
  int points = 0;           // TP packets acknowledged
  int device_slots = 0;     // the device's queue size reported by TB's AK
  int credit_polls = 0;     // QS sent to learn freed slots
  double duration_s = 0.0;  // sum of the points' dt
};

enum class Robots { kPhysical, kVirtual, kBoth };

// grip()/release() outcome of the virtual gripper (when it took part).
struct GripOutcome {
  bool virtual_closed = false;
  std::int32_t held_id = -1;  // the object the virtual gripper holds, -1 none
};

class Twin {
 public:
  // Either channel may be null (a twin with only one robot); statements that need it fail
  // with kNotConnected. `model` must outlive the Twin.
  Twin(const RobotModel& model, RobotChannel* physical, SimChannel* virtual_robot,
       TwinOptions options = {});

  // OperationMonitoring2: reads the physical joints (QS -> ST), converts motor steps and the
  // wrist servo angle to joints, stores the sample and returns it.
  Result<PhysicalJoints> read_physical_joints();
  // Everything read_physical_joints() stored, oldest first.
  std::vector<PhysicalJoints> stored_joints() const;

  // func_data: sends joints to the virtual robot (JD with the next sequence number and the
  // hub's time) and waits for the simulator's JA.
  Result<JointsApplied> send_joints_to_virtual(const JointVector& q);

  // func_point: the position of object `id` in the virtual scene.
  Result<protocol::ObjectPose> object_position(std::int32_t id);
  // Every object of the virtual scene.
  Result<std::vector<protocol::ObjectPose>> object_positions();

  // numberTran3: loads a joint trajectory into the physical robot: TB n, then one TP per
  // sample (absolute motor steps, wrist servo, dt to the previous sample in whole ms; the
  // first sample gets the first interval; gripper events go with the first sample at or
  // after their time), never more TP in flight than the device's free slots. Returns when
  // every point is acknowledged (the robot is then moving).
  Result<TrajectoryLoad> load_trajectory(const JointTrajectory& trajectory);
  // The side of its dead band each joint rests on (a calibrated description's backlash is
  // made up by leading each point by half of it in the direction the joint moves): the
  // homing's after HM, then each loaded trajectory's last.
  void set_directions(const MotionDirections& dir);

  // Closes / opens the gripper (physical: servo to the closed / open angle of the robot
  // description; virtual: GR 1 / 0).
  Result<GripOutcome> grip(Robots which = Robots::kBoth);
  Result<GripOutcome> release(Robots which = Robots::kBoth);

  // Takes a picture with the virtual camera (0 x 0: the description's size) and returns the
  // PNG bytes; with `save_as` (e.g. "image.png") also writes them to that file.
  Result<std::vector<std::uint8_t>> take_picture(const std::filesystem::path& save_as = {},
                                                 int width_px = 0, int height_px = 0);

 private:
  Result<GripOutcome> gripper(bool close, Robots which);

  const RobotModel& model_;
  RobotChannel* physical_;
  SimChannel* virtual_;
  TwinOptions options_;
  std::uint16_t jd_seq_ = 0;
  MotionDirections last_dir_{};
  mutable std::mutex log_mutex_;
  std::vector<PhysicalJoints> log_;
};

}  // namespace scaratwin::transport
