// The virtual robot: a MuJoCo simulation of the SCARA, its gripper and the sorting scene,
// generated from the robot description (mjcf.hpp). This class is single-threaded and
// deterministic: the same calls in the same order give bit-identical states. The thread-safe
// wrapper with real-time pacing is World (world.hpp).
//
// Two ways to move the robot:
//  - mirror: joint values are applied directly to the joint positions (as the paper's Unity
//    scene set transform.localRotation); the robot is kinematic, everything else obeys physics.
//  - simulate: position actuators follow a commanded joint trajectory with dynamics; gravity
//    and the joints' damping are fed forward so that the servos track without sag.
// Cubes obey physics in both. A grasp looks for a cube between the fingers (the paper's
// detector volume) and holds it: with a weld in simulate mode (its relative pose written from
// the current poses before activation), carried kinematically in mirror mode (a weld to a
// kinematic robot would pump the robot's overwritten motion into the cube). A release lets
// it fall.
//
// Units: SI (m, rad, s). Frames: positions are in the robot base B (the MJCF world frame);
// quaternions are (w, x, y, z) of the body in B.
#pragma once

#include <array>
#include <cstdint>
#include <deque>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "scaratwin/core/result.hpp"
#include "scaratwin/kinematics/kinematics.hpp"
#include "scaratwin/kinematics/robot_model.hpp"
#include "scaratwin/sim/mjcf.hpp"
#include "scaratwin/trajectory/trajectory.hpp"

struct mjModel_;
struct mjData_;

namespace scaratwin::sim {

// Error codes of the simulator: SimError (scaratwin/core/error_codes.hpp, 40..49).

enum class Mode { kMirror, kSimulate };
const char* mode_name(Mode mode);

struct SimOptions {
  MjcfOptions mjcf;
  std::size_t tool_path_points = 500;  // tool positions kept (one per tool_path_dt_s)
  double tool_path_dt_s = 0.02;
  std::size_t warnings_kept = 50;  // joint-limit warnings kept for the UI feed
};

// A cube of the pool that is in the scene.
struct CubeState {
  int id = -1;  // stable while the cube exists: colour * cubes_per_color + index in the pool
  CubeColor color = CubeColor::kRed;
  std::array<double, 3> pos_m{};  // centre in B
  std::array<double, 4> quat_wxyz{1, 0, 0, 0};
  bool held = false;  // welded to the gripper
};

// Joint values no robot of this description can have: beyond a joint's limits by more than
// the joint's whole range (max - min) on either side, or not finite. For the default robot:
// d1 outside -0.10 .. 0.23 m, q2 outside -325 .. 335 deg, q3 outside -355 .. 485 deg, q4
// outside -180 .. 360 deg. Values between the limits and this bound are plausible (a robot
// off its limits, mirrored as it is); values beyond it are garbage and refused. Returns the
// first such joint (0..3), or -1 when every value is plausible.
int implausible_joint(const RobotModel& robot, const JointVector& q);

// A joint value outside its limit (the value is applied anyway in mirror mode).
struct JointWarning {
  double time_s = 0.0;  // simulation time
  int joint = 0;        // 0..3 (j1..j4)
  double value = 0.0;   // m or rad
  JointLimit limit;
};

// Outcome of a grasp: grasping nothing is a normal outcome, not an error.
struct GraspResult {
  bool holding = false;
  int cube_id = -1;  // the cube held, or -1
};

// A point of the tool's recent path.
struct ToolPoint {
  double time_s = 0.0;
  std::array<double, 3> pos_m{};
};

class Simulation {
 public:
  // Generates the model from `robot`, compiles it and puts the robot at home with no cubes.
  static Result<std::unique_ptr<Simulation>> create(const RobotModel& robot,
                                                    const SimOptions& options = {});
  // An independent copy with the same state (for prediction runs); bit-exact continuation.
  Result<std::unique_ptr<Simulation>> clone() const;
  ~Simulation();
  Simulation(const Simulation&) = delete;
  Simulation& operator=(const Simulation&) = delete;

  // --- scene -----------------------------------------------------------------------------
  // Places a cube of `color` resting on the table at (x, y) with heading yaw. Fails without
  // changing the scene when the position is not finite, off the table, overlapping another
  // cube, or when every cube of the colour is in use.
  Result<CubeState> spawn_cube(CubeColor color, double x_m, double y_m, double yaw_rad = 0.0);
  // Removes every cube (and releases the gripper). The robot stays where it is.
  void reset_scene();
  // Every cube in the scene, ordered by id.
  std::vector<CubeState> cubes() const;
  Result<CubeState> cube(int id) const;
  int cubes_per_color() const { return pool_per_color_; }
  // The printed calibration pattern (a model built with MjcfOptions::pattern): lays it on the
  // table where the description's scene.pattern says, or takes it away (parked out of sight).
  // Error: the model has no pattern.
  Status show_pattern(bool on);
  bool pattern_shown() const { return pattern_shown_; }

  // --- motion ------------------------------------------------------------------------------
  Mode mode() const { return mode_; }
  // Switching to simulate holds the current joints; switching to mirror drops any trajectory.
  void set_mode(Mode mode);
  // Mirror: applies q at once (and at every step until the next call). Values outside their
  // limits are applied and reported. Errors: implausible (implausible_joint(): nothing
  // changes), simulate mode.
  Result<std::vector<JointWarning>> set_joints(const JointVector& q);
  // Simulate: follows `trajectory` from now on (times relative to now), executing its gripper
  // events. Samples outside the limits are clamped by the servos and reported. Errors: empty,
  // not finite, times not increasing from 0, mirror mode.
  Result<std::vector<JointWarning>> follow(const JointTrajectory& trajectory);
  // Simulate: holds q (a one-point move with the servos).
  Result<std::vector<JointWarning>> hold(const JointVector& q);
  // Simulate, prediction runs: appends one timed target to a stream. `t_s` is the target's
  // time on the sender's clock; the first target of a stream is played at once, the next ones
  // at their offsets from it (servo targets interpolated in between, velocity fed forward).
  // The stream stays open, holding its last target, until end_stream(), stop() or a mode
  // change; stream_horizon_s() tells how far it reaches, so that a caller stepping as fast as
  // it can stops there and waits for more (lockstep: the result does not depend on timing).
  // Errors: not finite, mirror mode, a time not after the previous target's.
  Result<std::vector<JointWarning>> stream_target(double t_s, const JointVector& q);
  bool stream_open() const { return traj_.has_value() && traj_->stream; }
  // Simulation time of the open stream's last target (or -infinity).
  double stream_horizon_s() const;
  void end_stream();
  // A grasp or release at the time of the open stream's last target; at once without one.
  void queue_gripper(GripperAction action);

  // Stops any trajectory and holds the current joints.
  void stop();
  // Puts the robot at its home pose at once (joints, velocities, targets), in either mode.
  Status reset_robot();
  bool trajectory_active() const { return traj_.has_value(); }

  // --- driven: the emulated physical robot ---------------------------------------------------
  // Simulate mode with the servos of j1..j3 switched off: their motion comes only from the
  // forces (N, N m) that the caller sets before each step (the plant's transmissions), while
  // j4 follows a position target (its hobby servo). The joints' damping and armature are
  // replaced by the given ones (the virtual robot's are sized for its position servos), with
  // a Coulomb friction (N, N m) for each; the fingers become solid (they push what they land
  // on). Trajectories are dropped; the gripper works as in simulate mode.
  void enable_drive(const std::array<double, 3>& damping, const std::array<double, 3>& armature,
                    const std::array<double, 3>& frictionloss);
  bool driven() const { return driven_; }
  void set_drive(const std::array<double, 3>& force, double wrist_target_rad);
  // A point mass held at the tool (a payload), kg; 0 takes it away.
  void set_payload(double mass_kg);
  double payload_kg() const { return payload_kg_; }
  JointVector joint_velocities() const;
  // The largest speed of any degree of freedom (m/s or rad/s): zero when all is at rest.
  double max_speed() const;

  // --- gripper ------------------------------------------------------------------------------
  // Closes the fingers and holds the cube between them if there is one.
  GraspResult grip();
  // Opens the fingers and lets a held cube go.
  void release();
  bool gripper_closed() const { return gripper_closed_; }
  int held_cube() const { return held_; }
  // The cube whose centre is inside the detector volume between the fingers, or -1.
  int cube_between_fingers() const;

  // --- time -----------------------------------------------------------------------------------
  // Advances n physics steps. A MuJoCo error restores the state before the call.
  Status step(int n = 1);
  // Steps until time_s() >= t (at least zero steps).
  Status step_until(double t_s);
  double time_s() const;
  double timestep_s() const;

  // --- state -----------------------------------------------------------------------------------
  JointVector joints() const;         // measured joint positions
  JointVector joint_targets() const;  // what the robot is told to be at now
  ToolPose tool_pose() const;         // of the `tool` site (yaw from its x axis)
  std::array<double, 3> tool_site_pos() const;
  std::vector<ToolPoint> tool_path() const;
  const std::deque<JointWarning>& recent_warnings() const { return warnings_; }
  // Off while the robot homes (it passes its soft limits on the way to its endstops, by design):
  // joints beyond their limits are then not warnings. On by default. A joint that stays beyond
  // its limit frame after frame is one warning, the next one when it leaves its limits again
  // (turning the warnings on starts afresh).
  void set_limit_warnings(bool on) {
    if (on && !limit_warnings_) outside_ = {};
    limit_warnings_ = on;
  }
  // On, afresh: every joint beyond its limits at its next note is a warning (a new hub).
  void restart_limit_warnings() {
    limit_warnings_ = true;
    outside_ = {};
  }
  bool limit_warnings() const { return limit_warnings_; }
  std::uint64_t warnings_total() const { return warnings_total_; }
  const RobotModel& robot() const { return robot_; }
  const SimOptions& options() const { return options_; }
  const std::string& mjcf() const { return mjcf_; }

  // The MuJoCo model and data (this simulation owns its model: grasps write eq_active and
  // eq_data in it). For the renderer and for tests; do not keep the pointers.
  const mjModel_* model() const { return m_; }
  const mjData_* data() const { return d_; }
  mjData_* mutable_data() { return d_; }

 private:
  Simulation() = default;
  Status init(const RobotModel& robot, const SimOptions& options);
  void park(int cube_id);
  void apply_mirror_pose();
  void apply_simulate_controls();
  void run_due_gripper_events();
  void record_tool_path();
  void set_fingers(bool closed);
  void carry_held_cube();
  std::vector<JointWarning> note_limits(const JointVector& q);
  JointWarning push_warning(int joint, double value);
  bool cube_active(int id) const { return active_[id]; }
  Status forward();

  struct Ids {
    std::array<int, kNumJoints> qpos{};  // qpos address of j1..j4
    std::array<int, kNumJoints> dof{};
    std::array<int, 2> finger_qpos{};
    std::array<int, 2> finger_dof{};
    std::array<int, kNumJoints + 2> actuator{};
    int tool_site = -1;
    int gripper_body = -1;
    std::vector<int> cube_body, cube_qpos, cube_dof, cube_geom, cube_weld;
  };

  RobotModel robot_;
  SimOptions options_;
  std::string mjcf_;
  mjModel_* m_ = nullptr;
  mjData_* d_ = nullptr;
  Ids ids_;
  int pool_per_color_ = 0;
  std::vector<char> active_;  // per cube id
  std::vector<int> geom_contype_, geom_conaffinity_;
  int pattern_geom_ = -1;                // -1: no pattern in the model
  std::array<double, 3> pattern_pos_{};  // where it lies when shown
  bool pattern_shown_ = false;

  Mode mode_ = Mode::kMirror;
  JointVector target_{};  // mirror pose or simulate hold point
  struct ActiveTrajectory {
    JointTrajectory trajectory;
    double start_s = 0.0;
    std::size_t next_event = 0;
    bool stream = false;       // built by stream_target(), open until ended
    double sender_t0_s = 0.0;  // sender's time of the stream's first target
  };
  std::optional<ActiveTrajectory> traj_;
  bool gripper_closed_ = false;
  bool driven_ = false;
  std::array<double, 3> drive_force_{};
  double drive_wrist_rad_ = 0.0;
  struct PayloadBase {
    double mass = 0.0;
    std::array<double, 3> ipos{}, inertia{};
  };
  std::optional<PayloadBase> payload_base_;
  double payload_kg_ = 0.0;
  int held_ = -1;

  std::deque<ToolPoint> path_;
  double next_path_s_ = 0.0;
  std::deque<JointWarning> warnings_;
  bool limit_warnings_ = true;
  std::array<bool, kNumJoints> outside_{};  // each joint beyond its limits at its last note
  std::uint64_t warnings_total_ = 0;
};

}  // namespace scaratwin::sim
