#include "scaratwin/plant/plant.hpp"

#include <algorithm>
#include <cmath>

#include "scaratwin/core/units.hpp"
#include "scaratwin/kinematics/motor.hpp"

namespace scaratwin::plant {
namespace {

// x beyond a dead band of half-width h (0 inside it)
double dead_band(double x, double h) {
  if (x > h) return x - h;
  if (x < -h) return x + h;
  return 0.0;
}

}  // namespace

// Coulomb friction of the joints' bearings and guides: Z N, J2 and J3 N m
const std::array<double, kSteppers> kJointFriction{2.0, 0.005, 0.003};

RobotModel as_built_robot(const RobotModel& description, const AsBuilt& a) {
  RobotModel m = description;
  m.name = description.name + " (as built)";
  m.dh[1].a_m += a[AsBuiltParam::kA2];
  m.dh[2].a_m += a[AsBuiltParam::kA3];
  m.dh[3].a_m += a[AsBuiltParam::kJawOffset];
  // the camera's mount: its position, its aim tilted about the camera's x and y axes, its roll
  CameraModel& cam = m.scene.camera;
  const std::array<double, 3> shift{a[AsBuiltParam::kCameraX], a[AsBuiltParam::kCameraY],
                                    a[AsBuiltParam::kCameraZ]};
  const double dist = std::sqrt(std::pow(cam.look_at_m[0] - cam.pos_m[0], 2) +
                                std::pow(cam.look_at_m[1] - cam.pos_m[1], 2) +
                                std::pow(cam.look_at_m[2] - cam.pos_m[2], 2));
  for (int i = 0; i < 3; ++i) {
    cam.pos_m[i] += shift[i];
    cam.look_at_m[i] += shift[i];
  }
  // a looking-down camera: a tilt about its x axis moves the aim point along y, about y
  // along x (small angles)
  cam.look_at_m[1] += dist * std::tan(a[AsBuiltParam::kCameraTiltX]);
  cam.look_at_m[0] += dist * std::tan(a[AsBuiltParam::kCameraTiltY]);
  // and turned about its optical axis
  cam.roll_rad += a[AsBuiltParam::kCameraRoll];
  return m;
}

Plant::~Plant() = default;

Result<std::unique_ptr<Plant>> Plant::create(const RobotModel& description, const AsBuilt& as_built,
                                             const PlantOptions& options) {
  if (!(options.timestep_s >= 1e-4 && options.timestep_s <= 0.005) || options.substeps < 1 ||
      options.timestep_s / options.substeps > 1e-4) {
    return Error{PlantError::kBadArgument,
                 "plant: timestep_s must be in [0.1, 5] ms with rotor steps of at most "
                 "100 us (substeps)"};
  }
  if (!(options.payload_kg >= 0.0 && options.payload_kg <= 2.0)) {
    return Error{PlantError::kBadArgument, "plant: payload_kg must be in [0, 2] kg"};
  }
  std::unique_ptr<Plant> p(new Plant());
  p->description_ = description;
  p->built_ = as_built_robot(description, as_built);
  p->as_built_ = as_built;
  p->options_ = options;
  if (Status s = validate(p->built_); !s) {
    return Error{PlantError::kInvalidRobot,
                 "plant: the as-built robot is not valid: " + s.error().message};
  }
  sim::SimOptions so;
  so.mjcf.timestep_s = options.timestep_s;
  so.mjcf.cubes_per_color = options.cubes_per_color;
  so.mjcf.pattern = true;
  so.mjcf.offscreen_width_px = kWebcamScale * p->built_.scene.camera.width_px;
  so.mjcf.offscreen_height_px = kWebcamScale * p->built_.scene.camera.height_px;
  auto sim = sim::Simulation::create(p->built_, so);
  if (!sim) return sim.error();
  p->sim_ = std::move(sim).value();
  if (Status s = p->sim_->show_pattern(false); !s) return s.error();

  const PhysicalModel& phys = description.physical;
  for (int i = 0; i < kSteppers; ++i)
    p->motors_.emplace_back(phys.drive.motor, phys.drive.supply_v);
  for (int i = 0; i < kSteppers; ++i) p->spr_[i] = steps_per_unit(description, i);
  p->coupling_ = description.motors.j3_per_j2_coupling;
  const double lead = 1.0 + as_built[AsBuiltParam::kZLead];
  p->dp_du_ = {};
  p->dp_du_[0][0] = lead / p->spr_[0];
  p->dp_du_[1][1] = 1.0 / p->spr_[1];
  p->dp_du_[2][2] = 1.0 / p->spr_[2];
  p->dp_du_[2][1] = -p->coupling_ / p->spr_[2];
  p->backlash_ = {as_built[AsBuiltParam::kZBacklash], as_built[AsBuiltParam::kJ2Backlash],
                  as_built[AsBuiltParam::kJ3Backlash]};
  const auto& sw = description.endstops.closes_at;
  p->switch_ = {sw[0] + as_built[AsBuiltParam::kZZero], sw[1] + as_built[AsBuiltParam::kJ2Zero],
                sw[2] + as_built[AsBuiltParam::kJ3Zero]};

  // power-up: the rotors where the start pose puts them, the joints where the rotors drive
  const JointVector start = options.start_given ? options.start : description.home;
  const MotorPosition mp = joints_to_motors(description, start);
  std::array<double, kSteppers> u{};
  for (int i = 0; i < kSteppers; ++i) {
    const auto n = static_cast<std::int64_t>(std::llround(mp.steps[i]));
    p->motors_[i].reset(n);
    u[i] = static_cast<double>(n);
  }
  const auto drive = p->drive_positions(u);
  JointVector q0{drive[0], drive[1], drive[2], start[3]};
  p->servo_deg_[1] = p->servo_target_deg_[1] = rad_to_deg(start[3]);
  q0[3] = start[3] + as_built[AsBuiltParam::kWristOffset];
  p->servo_deg_[0] = p->servo_target_deg_[0] = description.motors.gripper_open_deg;
  if (auto r = p->sim_->set_joints(q0); !r) return r.error();
  // light bearings instead of the virtual robot's servo damping; the rotors are modelled
  // apart, so only the arm's own reflected inertia remains in the armature
  p->sim_->enable_drive({20.0, 0.002, 0.001}, {0.0, 0.0, 0.0}, kJointFriction);
  p->sim_->set_drive({0.0, 0.0, 0.0}, q0[3]);
  if (options.payload_kg > 0.0) p->sim_->set_payload(options.payload_kg);
  p->q0_ = p->sim_->joints();
  p->qd0_ = {};
  p->update_endstops(p->q0_);
  return p;
}

std::array<double, kSteppers> Plant::drive_positions(const std::array<double, kSteppers>& u) const {
  std::array<double, kSteppers> p{};
  for (int j = 0; j < kSteppers; ++j) {
    for (int i = 0; i < kSteppers; ++i) p[j] += dp_du_[j][i] * u[i];
  }
  return p;
}

void Plant::step_pulse(int axis, bool forward, double t_s) {
  if (axis < 0 || axis >= kSteppers) return;
  pulses_.push_back({t_s, axis, forward ? 1 : -1});
  wake();
}

void Plant::servo_pulse(int servo, double width_us) {
  if (servo < 0 || servo > 1) return;
  const ServoSpec& spec = servo == 0 ? description_.motors.gripper : description_.motors.wrist;
  // hobby servos ignore pulses far outside their range (a glitch, not a command)
  if (width_us < 0.5 * spec.pulse_min_us || width_us > 1.5 * spec.pulse_max_us) return;
  const double w = std::clamp(width_us, spec.pulse_min_us, spec.pulse_max_us);
  const double gain =
      1.0 + as_built_[servo == 0 ? AsBuiltParam::kGripperGain : AsBuiltParam::kWristGain];
  const double nominal = (w - spec.pulse_min_us) / (spec.pulse_max_us - spec.pulse_min_us) *
                         (spec.max_deg - spec.min_deg);
  servo_target_deg_[servo] = spec.min_deg + nominal * gain;
  servo_powered_[servo] = true;
  // a servo that will move wakes the world
  const double dead_deg = rad_to_deg(as_built_[AsBuiltParam::kServoDeadband]);
  if (std::abs(servo_target_deg_[servo] - servo_deg_[servo]) > 0.5 * dead_deg) wake();
}

void Plant::update_servos(double dt_s) {
  const double dead_deg = rad_to_deg(as_built_[AsBuiltParam::kServoDeadband]);
  for (int s = 0; s < 2; ++s) {
    if (!servo_powered_[s]) continue;
    const ServoSpec& spec = s == 0 ? description_.motors.gripper : description_.motors.wrist;
    const double err = servo_target_deg_[s] - servo_deg_[s];
    // inside the dead band the servo's controller does nothing
    if (std::abs(err) <= 0.5 * dead_deg) continue;
    const double max_move = spec.max_speed_deg_s * dt_s;
    servo_deg_[s] += std::clamp(err, -max_move, max_move);
  }
  // the gripper: the jaws are closed past the middle of the servo's travel
  const double mid =
      0.5 * (description_.motors.gripper_open_deg + description_.motors.gripper_closed_deg);
  const bool closed = servo_deg_[0] > mid;
  if (closed != grip_closed_) {
    grip_closed_ = closed;
    if (closed) {
      (void)sim_->grip();  // holds a cube only if one lies between the jaws
    } else {
      sim_->release();
    }
  }
}

void Plant::update_endstops(const JointVector& q) {
  // each switch closes beyond the end of travel that homing moves towards
  std::uint8_t m = 0;
  for (int i = 0; i < kSteppers; ++i) {
    const bool closed =
        description_.endstops.homing_dir[i] > 0 ? q[i] >= switch_[i] : q[i] <= switch_[i];
    if (closed) m = static_cast<std::uint8_t>(m | (1u << i));
  }
  endstops_ = m;
}

void Plant::substep(double h) {
  const double t_end = time_s_ + h;
  while (!pulses_.empty() && pulses_.front().t_s <= t_end) {
    motors_[pulses_.front().axis].step(pulses_.front().dir);
    pulses_.pop_front();
  }
  // joints extrapolated within the physics step
  const double tau = t_end - step_start_s_;
  JointVector q{};
  for (int j = 0; j < kNumJoints; ++j) q[j] = q0_[j] + qd0_[j] * tau;
  std::array<double, kSteppers> u{}, ud{};
  for (int i = 0; i < kSteppers; ++i) {
    u[i] = motors_[i].angle_microsteps();
    ud[i] = motors_[i].speed_rad_s() / motors_[i].microstep_rad();
  }
  const auto p = drive_positions(u);
  const auto pd = drive_positions(ud);
  std::array<double, kSteppers> force{};
  for (int j = 0; j < kSteppers; ++j) {
    const double stretch = dead_band(p[j] - q[j], 0.5 * backlash_[j]);
    // the belt (or nut) pushes only while engaged; its damping acts only then
    force[j] = description_.physical.drive.stiffness[j] * stretch;
    if (stretch != 0.0) force[j] += description_.physical.drive.damping[j] * (pd[j] - qd0_[j]);
    force_sum_[j] += force[j];
  }
  for (int i = 0; i < kSteppers; ++i) {
    double load = 0.0;  // N m on rotor i: the joints' forces through dp/dtheta
    for (int j = 0; j < kSteppers; ++j) load += force[j] * dp_du_[j][i];
    load /= motors_[i].microstep_rad();
    motors_[i].advance(h, load);
  }
  time_s_ = t_end;
  update_endstops(q);
}

void Plant::finish_physics_step() {
  // the belt pulls the joint towards the drive (+k (p - q)): its mean over the rotor steps
  std::array<double, kSteppers> f{};
  for (int j = 0; j < kSteppers; ++j) f[j] = force_sum_[j] / options_.substeps;
  update_servos(options_.timestep_s);
  const double q4 = deg_to_rad(servo_deg_[1]) + as_built_[AsBuiltParam::kWristOffset];
  sim_->set_drive(f, q4);
  (void)sim_->step(1);
  force_sum_ = {};
  sub_ = 0;
  step_start_s_ += options_.timestep_s;
  q0_ = sim_->joints();
  qd0_ = sim_->joint_velocities();
  time_s_ = step_start_s_;  // the physics clock is the reference; no drift from the sum
  // 50 ms without motion anywhere: asleep until the next command
  quiet_steps_ = at_rest() ? quiet_steps_ + 1 : 0;
  if (quiet_steps_ >= 50) asleep_ = true;
}

bool Plant::at_rest() const {
  if (!pulses_.empty()) return false;
  for (const StepperMotor& m : motors_) {
    if (std::abs(m.speed_rad_s()) > 1e-4) return false;
  }
  const double dead_deg = rad_to_deg(as_built_[AsBuiltParam::kServoDeadband]);
  for (int s = 0; s < 2; ++s) {
    if (servo_powered_[s] && std::abs(servo_target_deg_[s] - servo_deg_[s]) > 0.5 * dead_deg) {
      return false;
    }
  }
  // every body of the world: the arm, the fingers and the cubes
  const JointVector v = sim_->joint_velocities();
  for (double x : v) {
    if (std::abs(x) > 1e-5) return false;
  }
  return sim_->max_speed() < 1e-5;
}

Status Plant::advance_to(double t_s) {
  const double h = options_.timestep_s / options_.substeps;
  if (asleep_ && pulses_.empty() && sub_ == 0) {
    // whole physics steps of nothing happening
    const double steps = std::floor((t_s + 1e-12 - step_start_s_) / options_.timestep_s);
    if (steps >= 1.0) {
      step_start_s_ += steps * options_.timestep_s;
      time_s_ = step_start_s_;
    }
    return Ok{};
  }
  while (time_s_ + h <= t_s + 1e-12) {
    substep(h);
    if (++sub_ == options_.substeps) finish_physics_step();
  }
  return Ok{};
}

Result<sim::CubeState> Plant::place_cube(CubeColor color, double x_m, double y_m, double yaw_rad) {
  wake();
  return sim_->spawn_cube(color, x_m, y_m, yaw_rad);
}

Status Plant::set_payload(double mass_kg) {
  if (!(mass_kg >= 0.0 && mass_kg <= 2.0))
    return Error{PlantError::kBadArgument, "payload must be in [0, 2] kg"};
  wake();
  sim_->set_payload(mass_kg);
  return Ok{};
}

void Plant::clear_cubes() {
  wake();
  sim_->reset_scene();
  grip_closed_ = false;
}

JointVector Plant::joints() const { return sim_->joints(); }
ToolPose Plant::tool_pose() const { return sim_->tool_pose(); }
std::vector<sim::CubeState> Plant::cubes() const { return sim_->cubes(); }
bool Plant::gripper_closed() const { return grip_closed_; }
int Plant::held_cube() const { return sim_->held_cube(); }

std::array<double, kSteppers> Plant::rotor_microsteps() const {
  return {motors_[0].angle_microsteps(), motors_[1].angle_microsteps(),
          motors_[2].angle_microsteps()};
}
std::array<std::int64_t, kSteppers> Plant::commanded_microsteps() const {
  return {motors_[0].commanded_microsteps(), motors_[1].commanded_microsteps(),
          motors_[2].commanded_microsteps()};
}
std::array<std::int64_t, kSteppers> Plant::lost_microsteps() const {
  return {motors_[0].lost_microsteps(), motors_[1].lost_microsteps(), motors_[2].lost_microsteps()};
}

}  // namespace scaratwin::plant
