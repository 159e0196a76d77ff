// Joint <-> motor conversion. Z, J2 and J3 are steppers counted in steps from the joint zero;
// the J3 motor also turns with J2 through the belt coupling (m3 = q3 * k3 + c * m2). The wrist
// (J4) and gripper are servos commanded in degrees. Pure functions of the robot model.
#pragma once

#include <array>
#include <cstdint>

#include "scaratwin/kinematics/robot_model.hpp"

namespace scaratwin {

inline constexpr int kNumSteppers = 3;  // Z, J2, J3

// Motor steps of the three steppers (not rounded) and the wrist servo angle.
struct MotorPosition {
  std::array<double, kNumSteppers> steps{};  // Z, J2, J3 motor steps from the joint zero
  double wrist_deg = 0.0;
};

// Motor position of a joint state (exact, not rounded).
MotorPosition joints_to_motors(const RobotModel& model, const JointVector& q);

// Nearest whole step counts of a joint state.
std::array<std::int32_t, kNumSteppers> joints_to_steps(const RobotModel& model,
                                                       const JointVector& q);

// Joint state from motor steps and the wrist servo angle.
JointVector motors_to_joints(const RobotModel& model, const std::array<double, kNumSteppers>& steps,
                             double wrist_deg);

// The calibration's joint map (RobotModel::calibration): the robot's true joints from the
// firmware's joint values and back, with the dead bands at their middle (dir 0). The identity
// for a description that was not calibrated.
JointVector firmware_to_joints(const RobotModel& model, const JointVector& q_fw);
JointVector joints_to_firmware(const RobotModel& model, const JointVector& q);

// Where a joint really is relative to the middle of its dead band, given the direction each
// stepper joint last moved (+1, -1, 0 unknown): -dir x backlash / 2 (index 3 is always 0).
JointVector backlash_shift(const RobotModel& model, const std::array<int, kNumSteppers>& dir);

// The direction each stepper joint last moved (+1, -1; 0 unknown), which decides the side of
// its dead band a joint rests on. Homing leaves each moving away from its switch.
using MotionDirections = std::array<int, kNumSteppers>;
MotionDirections homed_directions(const RobotModel& model);
// Updates `dir` with a move from `from` to `to` (a joint that did not move keeps its own).
void track_directions(MotionDirections& dir, const JointVector& from, const JointVector& to);

// Steps per joint unit of each stepper and its joint index (Z->d1, J2->q2, J3->q3).
double steps_per_unit(const RobotModel& model, int stepper);

// The step count each stepper's counter takes when its endstop switch closes (nearest whole
// step of the switch position x steps per unit). Z and J2 are motor counts; J3's is a joint
// count, without the J2 motor's coupling share, because its switch senses the joint.
std::array<std::int32_t, kNumSteppers> endstop_steps(const RobotModel& model);

}  // namespace scaratwin
