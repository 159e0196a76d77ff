// The driven mode of the simulation (simulation.hpp): the emulated physical robot's joints
// moved only by the forces of its transmissions, its payload, and the state the plant reads.
#include <algorithm>
#include <cmath>

#include <mujoco/mujoco.h>

#include "scaratwin/sim/simulation.hpp"

namespace scaratwin::sim {

void Simulation::enable_drive(const std::array<double, 3>& damping,
                              const std::array<double, 3>& armature,
                              const std::array<double, 3>& frictionloss) {
  set_mode(Mode::kSimulate);
  traj_.reset();
  driven_ = true;
  drive_force_ = {};
  drive_wrist_rad_ = joints()[3];
  for (int j = 0; j < 3; ++j) {
    const int a = ids_.actuator[j];
    m_->actuator_gainprm[a * mjNGAIN] = 0.0;
    m_->actuator_biasprm[a * mjNBIAS + 1] = 0.0;
    m_->dof_damping[ids_.dof[j]] = damping[j];
    m_->dof_armature[ids_.dof[j]] = armature[j];
    m_->dof_frictionloss[ids_.dof[j]] = frictionloss[j];
  }
  // physical jaws: the fingers touch the cubes (a jaw that lands on a cube pushes it)
  for (int f = 0; f < 2; ++f) {
    const int body = m_->jnt_bodyid[m_->dof_jntid[ids_.finger_dof[f]]];
    for (int g = 0; g < m_->body_geomnum[body]; ++g) {
      m_->geom_contype[m_->body_geomadr[body] + g] = 1;
      m_->geom_conaffinity[m_->body_geomadr[body] + g] = 1;
    }
  }
}

void Simulation::set_drive(const std::array<double, 3>& force, double wrist_target_rad) {
  drive_force_ = force;
  drive_wrist_rad_ = wrist_target_rad;
}

void Simulation::set_payload(double mass_kg) {
  // a point mass at the tool: the gripper body's mass, centre and inertia combined, from the
  // body as the model built it
  const int b = ids_.gripper_body;
  if (!payload_base_) {
    PayloadBase base;
    base.mass = m_->body_mass[b];
    for (int i = 0; i < 3; ++i) {
      base.ipos[i] = m_->body_ipos[3 * b + i];
      base.inertia[i] = m_->body_inertia[3 * b + i];
    }
    payload_base_ = base;
  }
  const PayloadBase& base = *payload_base_;
  const double extra = std::max(0.0, mass_kg);
  const double* tool_local = m_->site_pos + 3 * ids_.tool_site;
  const double m1 = base.mass + extra;
  for (int i = 0; i < 3; ++i) {
    m_->body_ipos[3 * b + i] = (base.mass * base.ipos[i] + extra * tool_local[i]) / m1;
    // a generous sphere of the payload about the new centre (its offset from the joints
    // dominates, and MuJoCo adds that itself)
    m_->body_inertia[3 * b + i] = base.inertia[i] + extra * 4e-5;
  }
  m_->body_mass[b] = m1;
  payload_kg_ = extra;
  // (no mj_setConst: it would put the joints back at qpos0; the dynamics read these fields
  // directly at every step)
}

double Simulation::max_speed() const {
  double m = 0.0;
  for (int i = 0; i < m_->nv; ++i) m = std::max(m, std::abs(d_->qvel[i]));
  return m;
}

JointVector Simulation::joint_velocities() const {
  JointVector v{};
  for (int j = 0; j < kNumJoints; ++j) v[j] = d_->qvel[ids_.dof[j]];
  return v;
}

}  // namespace scaratwin::sim
