// The driven mode of the simulation (simulation.hpp): the emulated physical robot's joints
// moved only by the forces of its transmissions, its payload, and the state the plant reads.
#include <algorithm>
#include <cmath>

#include <mujoco/mujoco.h>

#include "scaratwin/sim/simulation.hpp"

namespace scaratwin::sim {

void Simulation::enable_drive(const std::array<double, 3>& damping,
                              const std::array<double, 3>& armature,
                              const std::array<double, 3>& frictionloss, int robot) {
  set_mode(Mode::kSimulate, robot);
  Arm& arm_ = arm(robot);
  arm_.traj.reset();
  arm_.driven = true;
  arm_.drive_force = {};
  arm_.drive_wrist_rad = joints(robot)[3];
  for (int j = 0; j < 3; ++j) {
    const int a = arm_.actuator[j];
    m_->actuator_gainprm[a * mjNGAIN] = 0.0;
    m_->actuator_biasprm[a * mjNBIAS + 1] = 0.0;
    m_->dof_damping[arm_.dof[j]] = damping[j];
    m_->dof_armature[arm_.dof[j]] = armature[j];
    m_->dof_frictionloss[arm_.dof[j]] = frictionloss[j];
  }
  // physical jaws: the fingers touch the cubes (a jaw that lands on a cube pushes it)
  for (int f = 0; f < 2; ++f) {
    const int body = m_->jnt_bodyid[m_->dof_jntid[arm_.finger_dof[f]]];
    for (int g = 0; g < m_->body_geomnum[body]; ++g) {
      m_->geom_contype[m_->body_geomadr[body] + g] = 1;
      m_->geom_conaffinity[m_->body_geomadr[body] + g] = 1;
    }
  }
}

void Simulation::set_drive(const std::array<double, 3>& force, double wrist_target_rad, int robot) {
  Arm& a = arm(robot);
  a.drive_force = force;
  a.drive_wrist_rad = wrist_target_rad;
}

void Simulation::set_payload(double mass_kg, int robot) {
  Arm& a = arm(robot);
  // a point mass at the tool: the gripper body's mass, centre and inertia combined, from the
  // body as the model built it
  const int b = a.gripper_body;
  if (!a.payload_base) {
    PayloadBase base;
    base.mass = m_->body_mass[b];
    for (int i = 0; i < 3; ++i) {
      base.ipos[i] = m_->body_ipos[3 * b + i];
      base.inertia[i] = m_->body_inertia[3 * b + i];
    }
    a.payload_base = base;
  }
  const PayloadBase& base = *a.payload_base;
  const double extra = std::max(0.0, mass_kg);
  const double* tool_local = m_->site_pos + 3 * a.tool_site;
  const double m1 = base.mass + extra;
  for (int i = 0; i < 3; ++i) {
    m_->body_ipos[3 * b + i] = (base.mass * base.ipos[i] + extra * tool_local[i]) / m1;
    // a generous sphere of the payload about the new centre (its offset from the joints
    // dominates, and MuJoCo adds that itself)
    m_->body_inertia[3 * b + i] = base.inertia[i] + extra * 4e-5;
  }
  m_->body_mass[b] = m1;
  a.payload_kg = extra;
  // (no mj_setConst: it would put the joints back at qpos0; the dynamics read these fields
  // directly at every step)
}

double Simulation::max_speed() const {
  double m = 0.0;
  for (int i = 0; i < m_->nv; ++i) m = std::max(m, std::abs(d_->qvel[i]));
  return m;
}

JointVector Simulation::joint_velocities(int robot) const {
  const Arm& a = arm(robot);
  JointVector v{};
  for (int j = 0; j < kNumJoints; ++j) v[j] = d_->qvel[a.dof[j]];
  return v;
}

}  // namespace scaratwin::sim
