// The physical robot as built, for the emulator: a MuJoCo world of its own (the arm with the
// as-built link lengths, table, trays, physical cubes) driven only by what the firmware's pins
// do, and feeding back only what real hardware feeds back (the endstop switches).
//  - Z, J2 and J3: each STEP pulse moves a stepper's electrical angle one microstep; the
//    rotor follows through StepperMotor (stepper.hpp) and drives its joint through a
//    transmission: belts with compliance and a dead band (backlash), the J2 -> J3 belt
//    coupling of the description, the Z lead screw with its lead error.
//  - J4 and the gripper: hobby servos with a slew rate, a dead band and a gain error; the
//    wrist servo's horn sits on its spline with an offset. The gripper closes on a cube only
//    if one lies between its jaws.
//  - The endstops close where they were really glued: the description's `[endstops]` plus the
//    drawn joint zero offsets.
// Nothing here is shared with the hub or the simulator at run time; the truth it exposes
// (true joints, tool pose, cube poses, lost steps) is a measuring instrument for tests and
// reports, never an input of the twin.
//
// Time: emulated seconds, starting at 0. Inputs carry their time and must not go backwards;
// advance_to() integrates up to a time. Deterministic: the same inputs give the same truth.
#pragma once

#include <array>
#include <cstdint>
#include <deque>
#include <memory>
#include <vector>

#include "scaratwin/core/result.hpp"
#include "scaratwin/kinematics/kinematics.hpp"
#include "scaratwin/kinematics/physical.hpp"
#include "scaratwin/kinematics/robot_model.hpp"
#include "scaratwin/plant/stepper.hpp"
#include "scaratwin/sim/simulation.hpp"

namespace scaratwin::plant {

inline constexpr int kSteppers = 3;  // Z, J2, J3
// Coulomb friction of the joints' bearings and guides (Z N, J2 and J3 N m).
extern const std::array<double, kSteppers> kJointFriction;

struct PlantOptions {
  double timestep_s = 0.001;  // physics step of the arm and the cubes
  int substeps = 20;          // rotor integration steps per physics step (50 us)
  double payload_kg = 0.0;    // a mass held at the tool (tests of lost steps)
  int cubes_per_color = 4;
  // True joint values at power-up (the description's home by default, when empty).
  bool start_given = false;
  JointVector start{};
};

// The webcam's full resolution relative to the description's camera size: the plant renders
// pictures up to this many times its width and height.
inline constexpr int kWebcamScale = 2;

// The as-built description: the nominal one with the drawn link lengths, tool offset and
// camera mount applied.
RobotModel as_built_robot(const RobotModel& description, const AsBuilt& as_built);

class Plant {
 public:
  static Result<std::unique_ptr<Plant>> create(const RobotModel& description,
                                               const AsBuilt& as_built,
                                               const PlantOptions& options = {});
  ~Plant();

  // --- the firmware's pins -----------------------------------------------------------------
  // One STEP pulse of stepper `axis` (0 Z, 1 J2, 2 J3) in the direction its DIR pin gave, at
  // emulated time t_s (not before the last advance_to()).
  void step_pulse(int axis, bool forward, double t_s);
  // A complete servo pulse of `width_us` (servo 0 gripper, 1 wrist).
  void servo_pulse(int servo, double width_us);
  // Integrates up to t_s (rotors at 50 us resolution, the arm and cubes per physics step).
  Status advance_to(double t_s);

  // --- what the hardware feeds back -----------------------------------------------------------
  std::uint8_t endstops() const { return endstops_; }  // bit i: axis i's switch closed

  // --- the operator ---------------------------------------------------------------------------
  Result<sim::CubeState> place_cube(CubeColor color, double x_m, double y_m, double yaw_rad);
  void clear_cubes();
  // The operator hangs a mass on the tool (kg, 0..2; 0 takes it off).
  Status set_payload(double mass_kg);
  // The operator lays the printed calibration pattern on the table (registered to the base,
  // where the description's scene.pattern says) or takes it away. Off at power-up.
  Status set_pattern(bool on) { return sim_->show_pattern(on); }
  bool pattern_on() const { return sim_->pattern_shown(); }

  // --- the truth (measuring instruments only) -------------------------------------------------
  double time_s() const { return time_s_; }
  JointVector joints() const;  // true joint values (m, rad)
  ToolPose tool_pose() const;  // true tool pose in the base frame
  std::vector<sim::CubeState> cubes() const;
  bool gripper_closed() const;
  int held_cube() const;
  // Rotor positions in microsteps (continuous), the microsteps commanded, and those lost.
  std::array<double, kSteppers> rotor_microsteps() const;
  std::array<std::int64_t, kSteppers> commanded_microsteps() const;
  std::array<std::int64_t, kSteppers> lost_microsteps() const;
  const StepperMotor& motor(int axis) const { return motors_[axis]; }
  // Servo output angles (deg, as the servo sees them: 0 gripper, 1 wrist).
  double servo_deg(int servo) const { return servo_deg_[servo]; }
  const RobotModel& built() const { return built_; }
  const AsBuilt& as_built() const { return as_built_; }
  const sim::Simulation& world() const { return *sim_; }
  // True while the plant skips its physics because nothing moves (for benchmarks and tests).
  bool resting() const { return asleep_; }

 private:
  Plant() = default;
  void substep(double h);
  void finish_physics_step();
  void update_servos(double dt_s);
  void update_endstops(const JointVector& q);
  // Drive positions p_j (m, rad) of Z, J2, J3 from the rotors, and dp_j/du_i.
  std::array<double, kSteppers> drive_positions(const std::array<double, kSteppers>& u) const;

  RobotModel description_;
  RobotModel built_;
  AsBuilt as_built_;
  PlantOptions options_;
  std::unique_ptr<sim::Simulation> sim_;
  std::vector<StepperMotor> motors_;
  std::array<double, kSteppers> spr_{};  // description steps per joint unit
  double coupling_ = 0.0;                // J3 motor steps per J2 motor step
  std::array<std::array<double, kSteppers>, kSteppers> dp_du_{};  // [joint][motor]
  std::array<double, kSteppers> backlash_{};                      // dead band per joint
  std::array<double, kSteppers> switch_{};                        // true switch positions

  struct Pulse {
    double t_s;
    int axis;
    int dir;
  };
  std::deque<Pulse> pulses_;
  double time_s_ = 0.0;        // rotor time
  double step_start_s_ = 0.0;  // start of the current physics step
  int sub_ = 0;                // substeps done in the current physics step
  JointVector q0_{}, qd0_{};   // joints at the start of the physics step
  std::array<double, kSteppers> force_sum_{};
  std::uint8_t endstops_ = 0;
  // at rest: nothing moves until a pulse or a servo command, so whole physics steps are
  // skipped (the state is static; skipping changes no result)
  int quiet_steps_ = 0;
  bool asleep_ = false;
  void wake() {
    asleep_ = false;
    quiet_steps_ = 0;
  }
  bool at_rest() const;

  // servos: 0 gripper, 1 wrist; targets and outputs in servo degrees
  std::array<double, 2> servo_target_deg_{};
  std::array<double, 2> servo_deg_{};
  std::array<bool, 2> servo_powered_{};
  bool grip_closed_ = false;
};

}  // namespace scaratwin::plant
