// Simulation's motion: each robot's mode (mirror: the pose it is given; simulate: its servos
// follow a trajectory, a stream of targets or a hold), joint-limit notes, the gripper's timed
// events and the tool path. Model compilation and stepping are in simulation.cpp.
#include <algorithm>
#include <cmath>

#include <mujoco/mujoco.h>

#include "mj_guard.hpp"
#include "scaratwin/sim/simulation.hpp"
#include "sim_internal.hpp"

namespace scaratwin::sim {

using detail::finite;
using detail::implausible;
using detail::sample;
using detail::sim_error;

void Simulation::set_mode(Mode mode, int robot) {
  Arm& a = arm(robot);
  if (mode == a.mode) return;
  a.traj.reset();
  a.target = joints(robot);
  a.mode = mode;
  if (a.mode == Mode::kMirror) {
    for (int j = 0; j < kNumJoints; ++j) d_->qfrc_applied[a.dof[j]] = 0.0;
  }
  // a held cube: welded in simulate mode, carried kinematically in mirror mode
  if (a.held >= 0) m_->eq_active[a.cube_weld[a.held]] = a.mode == Mode::kSimulate ? 1 : 0;
}

JointWarning Simulation::push_warning(int robot, int joint, double value) {
  const JointWarning w{d_->time, joint, value, arm(robot).robot.limits[joint], robot};
  warnings_.push_back(w);
  ++warnings_total_;
  while (warnings_.size() > options_.warnings_kept) warnings_.pop_front();
  return w;
}

std::vector<JointWarning> Simulation::note_limits(int robot, const JointVector& q) {
  std::vector<JointWarning> out;
  Arm& a = arm(robot);
  if (!a.limit_warnings) return out;
  for (int j = 0; j < kNumJoints; ++j) {
    const bool outside = !a.robot.limits[j].contains(q[j]);
    if (outside && !a.outside[j]) out.push_back(push_warning(robot, j, q[j]));
    a.outside[j] = outside;
  }
  return out;
}

Result<std::vector<JointWarning>> Simulation::set_joints(const JointVector& q, int robot) {
  if (Status st = check_robot(robot); !st) return st.error();
  Arm& a = arm(robot);
  if (const int j = implausible_joint(a.robot, q); j >= 0) return implausible(a.robot, q, j);
  if (a.mode != Mode::kMirror) {
    return sim_error(SimError::kWrongMode,
                     "joint data are applied in mirror mode; the simulator is in simulate mode");
  }
  auto warnings = note_limits(robot, q);
  a.target = q;
  apply_mirror_pose(a);
  // poses only (the next step computes the dynamics); a joint frame costs microseconds
  struct Kin {
    Simulation* s;
    Arm* a;
    void operator()() {
      mj_kinematics(s->m_, s->d_);
      if (a->held >= 0) {
        s->carry_held_cube(*a);
        mj_kinematics(s->m_, s->d_);
      }
    }
  } kin{this, &a};
  if (Status st = detail::mj_guarded(static_cast<int>(SimError::kMujoco), "mj_kinematics", kin);
      !st) {
    return st.error();
  }
  return warnings;
}

Result<std::vector<JointWarning>> Simulation::follow(const JointTrajectory& t, int robot) {
  if (Status st = check_robot(robot); !st) return st.error();
  Arm& arm_ = arm(robot);
  if (arm_.mode != Mode::kSimulate) {
    return sim_error(SimError::kWrongMode,
                     "trajectories are followed in simulate mode; the simulator is in mirror mode");
  }
  if (t.samples.empty()) return sim_error(SimError::kBadArgument, "trajectory has no samples");
  if (t.samples.front().t_s != 0.0) {
    return sim_error(
        SimError::kBadArgument,
        fmt::format("trajectory starts at t = {} s; it must start at 0", t.samples.front().t_s));
  }
  for (std::size_t i = 0; i < t.samples.size(); ++i) {
    const JointSample& s = t.samples[i];
    if (!std::isfinite(s.t_s) || !finite(s.q) || !finite(s.qd)) {
      return sim_error(SimError::kBadArgument, fmt::format("sample {} is not finite", i));
    }
    if (i > 0 && !(s.t_s > t.samples[i - 1].t_s)) {
      return sim_error(SimError::kBadArgument,
                       fmt::format("sample {} at t = {} s does not come after {} s", i, s.t_s,
                                   t.samples[i - 1].t_s));
    }
  }
  for (const GripperEvent& e : t.events) {
    if (!std::isfinite(e.t_s)) return sim_error(SimError::kBadArgument, "event time not finite");
  }
  // one warning per joint: its first sample outside the limits
  std::vector<JointWarning> warnings;
  std::array<bool, kNumJoints> seen{};
  for (const JointSample& s : t.samples) {
    for (int j = 0; j < kNumJoints; ++j) {
      if (seen[j] || arm_.robot.limits[j].contains(s.q[j])) continue;
      seen[j] = true;
      warnings.push_back(push_warning(robot, j, s.q[j]));
    }
  }
  ActiveTrajectory a;
  a.trajectory = t;
  std::stable_sort(a.trajectory.events.begin(), a.trajectory.events.end(),
                   [](const GripperEvent& x, const GripperEvent& y) { return x.t_s < y.t_s; });
  a.start_s = d_->time;
  arm_.traj = std::move(a);
  return warnings;
}

Result<std::vector<JointWarning>> Simulation::hold(const JointVector& q, int robot) {
  if (Status st = check_robot(robot); !st) return st.error();
  Arm& a = arm(robot);
  if (const int j = implausible_joint(a.robot, q); j >= 0) return implausible(a.robot, q, j);
  if (a.mode != Mode::kSimulate) {
    return sim_error(SimError::kWrongMode, "hold is a simulate-mode command");
  }
  auto warnings = note_limits(robot, q);
  a.traj.reset();
  a.target = q;
  return warnings;
}

Result<std::vector<JointWarning>> Simulation::stream_target(double t_s, const JointVector& q,
                                                            int robot) {
  if (Status st = check_robot(robot); !st) return st.error();
  Arm& arm_ = arm(robot);
  if (!std::isfinite(t_s) || !finite(q)) {
    return sim_error(SimError::kBadArgument, "stream target time and joints must be finite");
  }
  if (const int j = implausible_joint(arm_.robot, q); j >= 0) {
    return implausible(arm_.robot, q, j);
  }
  if (arm_.mode != Mode::kSimulate) {
    return sim_error(SimError::kWrongMode, "joint targets are followed in simulate mode");
  }
  if (stream_open(robot)) {
    JointTrajectory& t = arm_.traj->trajectory;
    const JointSample& last = t.samples.back();
    const double t_rel = t_s - arm_.traj->sender_t0_s;
    if (!(t_rel > last.t_s + 1e-9)) {
      return sim_error(SimError::kBadArgument,
                       fmt::format("stream target at {} s does not come after the previous one "
                                   "at {} s",
                                   t_rel, last.t_s));
    }
    JointSample next{t_rel, q, {}, {}};
    for (int j = 0; j < kNumJoints; ++j) next.qd[j] = (q[j] - last.q[j]) / (t_rel - last.t_s);
    auto warnings = note_limits(robot, q);
    t.samples.push_back(next);
    return warnings;
  }
  auto warnings = note_limits(robot, q);
  ActiveTrajectory a;
  a.stream = true;
  a.sender_t0_s = t_s;
  a.start_s = d_->time;
  a.trajectory.samples.push_back(JointSample{0.0, q, {}, {}});
  arm_.traj = std::move(a);
  return warnings;
}

double Simulation::stream_horizon_s(int robot) const {
  if (!stream_open(robot)) return -INFINITY;
  const Arm& a = arm(robot);
  return a.traj->start_s + a.traj->trajectory.samples.back().t_s;
}

void Simulation::end_stream(int robot) {
  if (stream_open(robot)) arm(robot).traj->stream = false;  // finishes like any trajectory
}

void Simulation::queue_gripper(GripperAction action, int robot) {
  if (stream_open(robot)) {
    JointTrajectory& t = arm(robot).traj->trajectory;
    t.events.push_back(GripperEvent{t.samples.back().t_s, action});
    return;
  }
  if (action == GripperAction::kGrip) {
    (void)grip(robot);
  } else {
    release(robot);
  }
}

void Simulation::stop(int robot) {
  Arm& a = arm(robot);
  a.traj.reset();
  if (a.mode == Mode::kSimulate) a.target = joints(robot);
}

Status Simulation::reset_robot(int robot) {
  if (Status st = check_robot(robot); !st) return st;
  Arm& a = arm(robot);
  a.traj.reset();
  a.target = a.robot.home;
  for (int j = 0; j < kNumJoints; ++j) {
    d_->qpos[a.qpos[j]] = a.target[j];
    d_->qvel[a.dof[j]] = 0.0;
    d_->ctrl[a.actuator[j]] = a.target[j];
  }
  if (a.held >= 0) {
    mj_kinematics(m_, d_);
    carry_held_cube(a);
  }
  return forward();
}

void Simulation::apply_mirror_pose(Arm& a) {
  const GripperGeometry g = gripper_geometry(a.robot);
  for (int j = 0; j < kNumJoints; ++j) {
    d_->qpos[a.qpos[j]] = a.target[j];
    d_->qvel[a.dof[j]] = 0.0;
  }
  for (int f = 0; f < 2; ++f) {
    d_->qpos[a.finger_qpos[f]] = a.gripper_closed ? 0.0 : g.open_travel_m;
    d_->qvel[a.finger_dof[f]] = 0.0;
  }
}

void Simulation::apply_simulate_controls(Arm& a) {
  if (a.driven) {
    for (int j = 0; j < 3; ++j) {
      d_->ctrl[a.actuator[j]] = 0.0;
      d_->qfrc_applied[a.dof[j]] = a.drive_force[j];
    }
    d_->ctrl[a.actuator[3]] = a.drive_wrist_rad;
    d_->qfrc_applied[a.dof[3]] = d_->qfrc_bias[a.dof[3]];
    const GripperGeometry g = gripper_geometry(a.robot);
    for (int f = 0; f < 2; ++f) {
      d_->ctrl[a.actuator[kNumJoints + f]] = a.gripper_closed ? 0.0 : g.open_travel_m;
    }
    return;
  }
  JointVector q = a.target, qd{};
  if (a.traj) {
    std::size_t hint = 0;
    sample(a.traj->trajectory, d_->time - a.traj->start_s, hint, q, qd);
  }
  for (int j = 0; j < kNumJoints; ++j) {
    d_->ctrl[a.actuator[j]] = q[j];
    // feed forward gravity, Coriolis and the joint damping at the reference velocity
    const int dof = a.dof[j];
    d_->qfrc_applied[dof] = d_->qfrc_bias[dof] + m_->dof_damping[dof] * qd[j];
  }
  const GripperGeometry g = gripper_geometry(a.robot);
  for (int f = 0; f < 2; ++f) {
    d_->ctrl[a.actuator[kNumJoints + f]] = a.gripper_closed ? 0.0 : g.open_travel_m;
  }
}

void Simulation::run_due_gripper_events(int robot) {
  Arm& a = arm(robot);
  if (!a.traj) return;
  const double t_rel = d_->time - a.traj->start_s;
  auto& events = a.traj->trajectory.events;
  while (a.traj->next_event < events.size() && events[a.traj->next_event].t_s <= t_rel + 1e-12) {
    if (events[a.traj->next_event].action == GripperAction::kGrip) {
      grip(robot);
    } else {
      release(robot);
    }
    ++a.traj->next_event;
  }
  if (!a.traj->stream && t_rel > a.traj->trajectory.duration_s() &&
      a.traj->next_event >= events.size()) {
    a.target = a.traj->trajectory.samples.back().q;
    a.traj.reset();
  }
}

void Simulation::record_tool_path(Arm& a) {
  if (d_->time + 1e-12 < a.next_path_s) return;
  const double* p = d_->site_xpos + 3 * a.tool_site;
  a.path.push_back(ToolPoint{d_->time, {p[0], p[1], p[2]}});
  while (a.path.size() > options_.tool_path_points) a.path.pop_front();
  a.next_path_s = d_->time + options_.tool_path_dt_s;
}

}  // namespace scaratwin::sim
