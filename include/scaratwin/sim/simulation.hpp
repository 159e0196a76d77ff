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
// A workcell of several robots is simulated in one model (one scene, shared cubes): each robot
// has its own mode, trajectory, gripper and joint-limit notes (the per-robot methods take its
// index; without it they address robot 0, the paper's robot).
//
// Units: SI (m, rad, s). Frames: positions are in the world frame W, which is robot 0's base B
// (the MJCF world frame); quaternions are (w, x, y, z) of the body in W.
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
#include "scaratwin/kinematics/workcell.hpp"
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
  int robot = 0;  // the robot's index in the workcell
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
  // The simulation of the workcell of that one robot (single_robot_workcell()).
  static Result<std::unique_ptr<Simulation>> create(const RobotModel& robot,
                                                    const SimOptions& options = {});
  // The simulation of a workcell (docs/workcell.md): its scene once, each robot at its base
  // pose with its own mode, trajectory, gripper and joint-limit notes; the cubes are shared
  // (one arm cannot take a cube another holds). Robot i of the workcell is index i of every
  // per-robot method below; a method without the index addresses robot 0. Errors:
  // validate(Workcell)'s, and those of create(RobotModel).
  static Result<std::unique_ptr<Simulation>> create(const Workcell& workcell,
                                                    const SimOptions& options = {});
  // An independent copy with the same state (for prediction runs); bit-exact continuation.
  Result<std::unique_ptr<Simulation>> clone() const;
  ~Simulation();
  Simulation(const Simulation&) = delete;
  Simulation& operator=(const Simulation&) = delete;

  // --- robots --------------------------------------------------------------------------------
  int robot_count() const { return static_cast<int>(arms_.size()); }
  // Robot `robot`'s name in the workcell ("robot" for the paper's single robot).
  const std::string& robot_name(int robot = 0) const { return arm(robot).name; }
  const BasePose& robot_base(int robot = 0) const { return arm(robot).base; }
  // Ok when `robot` is one of the simulation's robots; SimError::kNoRobot, naming the robots
  // there are, otherwise. The per-robot methods that return a Result check it; the others take
  // it as a precondition (a bad index is a programming error).
  Status check_robot(int robot) const;

  // --- scene -----------------------------------------------------------------------------
  // Places a cube of `color` resting on the table at (x, y) with heading yaw. Fails without
  // changing the scene when the position is not finite, off the table, overlapping another
  // cube, or when every cube of the colour is in use.
  Result<CubeState> spawn_cube(CubeColor color, double x_m, double y_m, double yaw_rad = 0.0);
  // Removes every cube (and releases every gripper). The robots stay where they are.
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

  // --- motion (each robot's own) -------------------------------------------------------------
  Mode mode(int robot = 0) const { return arm(robot).mode; }
  // Switching to simulate holds the current joints; switching to mirror drops any trajectory.
  void set_mode(Mode mode, int robot = 0);
  // Mirror: applies q at once (and at every step until the next call). Values outside their
  // limits are applied and reported. Errors: implausible (implausible_joint(): nothing
  // changes), simulate mode, no such robot.
  Result<std::vector<JointWarning>> set_joints(const JointVector& q, int robot = 0);
  // Simulate: follows `trajectory` from now on (times relative to now), executing its gripper
  // events. Samples outside the limits are clamped by the servos and reported. Errors: empty,
  // not finite, times not increasing from 0, mirror mode, no such robot.
  Result<std::vector<JointWarning>> follow(const JointTrajectory& trajectory, int robot = 0);
  // Simulate: holds q (a one-point move with the servos).
  Result<std::vector<JointWarning>> hold(const JointVector& q, int robot = 0);
  // Simulate, prediction runs: appends one timed target to a stream. `t_s` is the target's
  // time on the sender's clock; the first target of a stream is played at once, the next ones
  // at their offsets from it (servo targets interpolated in between, velocity fed forward).
  // The stream stays open, holding its last target, until end_stream(), stop() or a mode
  // change; stream_horizon_s() tells how far it reaches, so that a caller stepping as fast as
  // it can stops there and waits for more (lockstep: the result does not depend on timing).
  // Errors: not finite, mirror mode, a time not after the previous target's, no such robot.
  Result<std::vector<JointWarning>> stream_target(double t_s, const JointVector& q, int robot = 0);
  bool stream_open(int robot = 0) const {
    const Arm& a = arm(robot);
    return a.traj.has_value() && a.traj->stream;
  }
  // Simulation time of the open stream's last target (or -infinity).
  double stream_horizon_s(int robot = 0) const;
  void end_stream(int robot = 0);
  // A grasp or release at the time of the open stream's last target; at once without one.
  void queue_gripper(GripperAction action, int robot = 0);

  // Stops any trajectory and holds the current joints.
  void stop(int robot = 0);
  // Puts the robot at its home pose at once (joints, velocities, targets), in either mode.
  Status reset_robot(int robot = 0);
  bool trajectory_active(int robot = 0) const { return arm(robot).traj.has_value(); }

  // --- driven: the emulated physical robot ---------------------------------------------------
  // Simulate mode with the servos of j1..j3 switched off: their motion comes only from the
  // forces (N, N m) that the caller sets before each step (the plant's transmissions), while
  // j4 follows a position target (its hobby servo). The joints' damping and armature are
  // replaced by the given ones (the virtual robot's are sized for its position servos), with
  // a Coulomb friction (N, N m) for each; the fingers become solid (they push what they land
  // on). Trajectories are dropped; the gripper works as in simulate mode.
  void enable_drive(const std::array<double, 3>& damping, const std::array<double, 3>& armature,
                    const std::array<double, 3>& frictionloss, int robot = 0);
  bool driven(int robot = 0) const { return arm(robot).driven; }
  void set_drive(const std::array<double, 3>& force, double wrist_target_rad, int robot = 0);
  // A point mass held at the tool (a payload), kg; 0 takes it away.
  void set_payload(double mass_kg, int robot = 0);
  double payload_kg(int robot = 0) const { return arm(robot).payload_kg; }
  JointVector joint_velocities(int robot = 0) const;
  // The largest speed of any degree of freedom (m/s or rad/s): zero when all is at rest.
  double max_speed() const;

  // --- gripper ------------------------------------------------------------------------------
  // Closes the fingers and holds the cube between them if there is one (and no other robot
  // holds it).
  GraspResult grip(int robot = 0);
  // Opens the fingers and lets a held cube go.
  void release(int robot = 0);
  bool gripper_closed(int robot = 0) const { return arm(robot).gripper_closed; }
  int held_cube(int robot = 0) const { return arm(robot).held; }
  // The cube whose centre is inside the detector volume between the fingers, or -1.
  int cube_between_fingers(int robot = 0) const;

  // --- time -----------------------------------------------------------------------------------
  // Advances n physics steps. A MuJoCo error restores the state before the call.
  Status step(int n = 1);
  // Steps until time_s() >= t (at least zero steps).
  Status step_until(double t_s);
  double time_s() const;
  double timestep_s() const;

  // --- state (positions in the world frame W: robot 0's base frame) ---------------------------
  JointVector joints(int robot = 0) const;         // measured joint positions
  JointVector joint_targets(int robot = 0) const;  // what the robot is told to be at now
  ToolPose tool_pose(int robot = 0) const;         // of the `tool` site (yaw from its x axis)
  std::array<double, 3> tool_site_pos(int robot = 0) const;
  std::vector<ToolPoint> tool_path(int robot = 0) const;
  // Touches between the arms of different robots. In a workcell of more than one robot each
  // arm collides with the other robots' arms (its column and links, not its gripper's pads),
  // never with its own or with the table and the cubes; a touch is counted once however many
  // steps it lasts.
  struct ArmContacts {
    int count = 0;     // touches so far
    int robot_a = -1;  // the last one's robots (a < b), -1 before any
    int robot_b = -1;
    double t_s = 0.0;  // and its simulation time
  };
  ArmContacts arm_contacts() const { return arm_contacts_; }
  // Joint-limit warnings of every robot (JointWarning::robot), the latest warnings_kept.
  const std::deque<JointWarning>& recent_warnings() const { return warnings_; }
  // Off while a robot homes (it passes its soft limits on the way to its endstops, by
  // design): its joints beyond their limits are then not warnings. On by default, per robot.
  // A joint that stays beyond its limit frame after frame is one warning, the next one when it
  // leaves its limits again (turning the warnings on starts afresh).
  void set_limit_warnings(bool on, int robot = 0) {
    Arm& a = arm(robot);
    if (on && !a.limit_warnings) a.outside = {};
    a.limit_warnings = on;
  }
  // On, afresh: every joint of the robot beyond its limits at its next note is a warning (a
  // new hub of that robot).
  void restart_limit_warnings(int robot) {
    Arm& a = arm(robot);
    a.limit_warnings = true;
    a.outside = {};
  }
  // The same for every robot (a new hub of the whole simulator).
  void restart_limit_warnings() {
    for (int r = 0; r < robot_count(); ++r) restart_limit_warnings(r);
  }
  bool limit_warnings(int robot = 0) const { return arm(robot).limit_warnings; }
  std::uint64_t warnings_total() const { return warnings_total_; }
  // Robot `robot`'s description (robot 0: the paper's robot; its scene is the workcell's).
  const RobotModel& robot(int robot = 0) const { return arm(robot).robot; }
  const Workcell& workcell() const { return workcell_; }
  const SimOptions& options() const { return options_; }
  const std::string& mjcf() const { return mjcf_; }

  // The MuJoCo model and data (this simulation owns its model: grasps write eq_active and
  // eq_data in it). For the renderer and for tests; do not keep the pointers.
  const mjModel_* model() const { return m_; }
  const mjData_* data() const { return d_; }
  mjData_* mutable_data() { return d_; }

 private:
  struct ActiveTrajectory {
    JointTrajectory trajectory;
    double start_s = 0.0;
    std::size_t next_event = 0;
    bool stream = false;       // built by stream_target(), open until ended
    double sender_t0_s = 0.0;  // sender's time of the stream's first target
  };
  struct PayloadBase {
    double mass = 0.0;
    std::array<double, 3> ipos{}, inertia{};
  };
  // One robot of the workcell: its elements in the model and its own state.
  struct Arm {
    std::string name;
    BasePose base;
    RobotModel robot;                    // its scene: the workcell's
    std::array<int, kNumJoints> qpos{};  // qpos address of j1..j4
    std::array<int, kNumJoints> dof{};
    std::array<int, 2> finger_qpos{};
    std::array<int, 2> finger_dof{};
    std::array<int, kNumJoints + 2> actuator{};
    int tool_site = -1;
    int gripper_body = -1;
    std::vector<int> cube_weld;  // per cube id: this gripper's weld to it

    Mode mode = Mode::kMirror;
    JointVector target{};  // mirror pose or simulate hold point
    std::optional<ActiveTrajectory> traj;
    bool gripper_closed = false;
    bool driven = false;
    std::array<double, 3> drive_force{};
    double drive_wrist_rad = 0.0;
    std::optional<PayloadBase> payload_base;
    double payload_kg = 0.0;
    int held = -1;
    std::deque<ToolPoint> path;
    double next_path_s = 0.0;
    std::array<bool, kNumJoints> outside{};  // each joint beyond its limits at its last note
    bool limit_warnings = true;              // off while it homes
  };

  Simulation() = default;
  Status init(const Workcell& workcell, const SimOptions& options);
  const Arm& arm(int robot) const;
  Arm& arm(int robot);
  void park(int cube_id);
  void apply_mirror_pose(Arm& a);
  void apply_simulate_controls(Arm& a);
  void run_due_gripper_events(int robot);
  void record_tool_path(Arm& a);
  void set_fingers(Arm& a, bool closed);
  void carry_held_cube(Arm& a);
  std::vector<JointWarning> note_limits(int robot, const JointVector& q);
  JointWarning push_warning(int robot, int joint, double value);
  int holder_of(int cube_id) const;  // the robot holding the cube, or -1
  void setup_arm_collisions();
  void note_arm_contacts();
  bool cube_active(int id) const { return active_[id]; }
  Status forward();

  Workcell workcell_;
  SimOptions options_;
  std::string mjcf_;
  mjModel_* m_ = nullptr;
  mjData_* d_ = nullptr;
  std::vector<Arm> arms_;
  // the cube pool, per cube id
  int pool_per_color_ = 0;
  std::vector<int> cube_body_, cube_qpos_, cube_dof_, cube_geom_;
  std::vector<char> active_;
  std::vector<int> geom_contype_, geom_conaffinity_;
  int pattern_geom_ = -1;                // -1: no pattern in the model
  std::array<double, 3> pattern_pos_{};  // where it lies when shown
  bool pattern_shown_ = false;

  std::deque<JointWarning> warnings_;
  std::vector<int> geom_robot_;  // per geom: the robot whose arm it is (-1: none), >1 robot
  std::vector<char> touching_;   // per pair of robots (a * n + b): touching at the last step
  ArmContacts arm_contacts_;
  std::uint64_t warnings_total_ = 0;
};

}  // namespace scaratwin::sim
