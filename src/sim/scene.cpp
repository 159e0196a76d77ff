// Simulation: the cube pool (spawn, park, reset, poses) and the gripper (detector and weld).
#include <algorithm>
#include <cmath>

#include <fmt/format.h>
#include <mujoco/mujoco.h>

#include "scaratwin/sim/simulation.hpp"
#include "sim_internal.hpp"

namespace scaratwin::sim {

using detail::sim_error;

void Simulation::park(int k) {
  const int q = cube_qpos_[k];
  for (int i = 0; i < 7; ++i) d_->qpos[q + i] = m_->qpos0[q + i];
  for (int i = 0; i < 6; ++i) d_->qvel[cube_dof_[k] + i] = 0.0;
  const int g = cube_geom_[k];
  m_->geom_contype[g] = 0;
  m_->geom_conaffinity[g] = 0;
  for (Arm& a : arms_) {
    if (a.held == k) {
      m_->eq_active[a.cube_weld[k]] = 0;
      a.held = -1;
    }
  }
  active_[k] = 0;
}

int Simulation::holder_of(int k) const {
  for (std::size_t r = 0; r < arms_.size(); ++r) {
    if (arms_[r].held == k) return static_cast<int>(r);
  }
  return -1;
}

Result<CubeState> Simulation::spawn_cube(CubeColor color, double x_m, double y_m, double yaw_rad) {
  const int c = static_cast<int>(color);
  if (c < 0 || c >= kNumColors) {
    return sim_error(SimError::kBadArgument,
                     fmt::format("colour {} is not one of red (0), green (1), blue (2)", c));
  }
  if (!std::isfinite(x_m) || !std::isfinite(y_m) || !std::isfinite(yaw_rad)) {
    return sim_error(SimError::kBadArgument, "spawn position and yaw must be finite");
  }
  const double cube = workcell_.scene.cube_size_m;
  const int table = mj_name2id(m_, mjOBJ_GEOM, "table");
  SCARATWIN_CHECK(table >= 0, "generated model lacks the table");
  const double* tp = m_->geom_pos + 3 * table;
  const double* ts = m_->geom_size + 3 * table;
  const double x_lo = tp[0] - ts[0] + cube, x_hi = tp[0] + ts[0] - cube;
  const double y_lo = tp[1] - ts[1] + cube, y_hi = tp[1] + ts[1] - cube;
  if (x_m < x_lo || x_m > x_hi || y_m < y_lo || y_m > y_hi) {
    return sim_error(SimError::kBadArgument,
                     fmt::format("spawn at ({:.4f}, {:.4f}) m is off the table: x must be in "
                                 "[{:.4f}, {:.4f}] m and y in [{:.4f}, {:.4f}] m",
                                 x_m, y_m, x_lo, x_hi, y_lo, y_hi));
  }
  // two cubes closer than a diagonal may intersect whatever their headings
  const double min_dist = cube * std::sqrt(2.0);
  for (std::size_t k = 0; k < active_.size(); ++k) {
    if (!active_[k]) continue;
    const double* p = d_->qpos + cube_qpos_[k];
    if (std::hypot(p[0] - x_m, p[1] - y_m) < min_dist &&
        std::abs(p[2] - workcell_.scene.table_z_m) < 2 * cube) {
      return sim_error(SimError::kOccupied,
                       fmt::format("spawn at ({:.4f}, {:.4f}) m overlaps cube {} at ({:.4f}, "
                                   "{:.4f}) m; keep {:.4f} m between centres",
                                   x_m, y_m, k, p[0], p[1], min_dist));
    }
  }
  int k = -1;
  for (int i = 0; i < pool_per_color_; ++i) {
    if (!active_[c * pool_per_color_ + i]) {
      k = c * pool_per_color_ + i;
      break;
    }
  }
  if (k < 0) {
    return sim_error(SimError::kPoolExhausted,
                     fmt::format("all {} {} cubes are in the scene; reset or raise "
                                 "cubes_per_color",
                                 pool_per_color_, color_name(color)));
  }
  const int q = cube_qpos_[k];
  // resting on the table (2 mm above, so that a tray floor is not intersected)
  d_->qpos[q + 0] = x_m;
  d_->qpos[q + 1] = y_m;
  d_->qpos[q + 2] = workcell_.scene.table_z_m + 0.5 * cube + 0.002;
  d_->qpos[q + 3] = std::cos(0.5 * yaw_rad);
  d_->qpos[q + 4] = 0.0;
  d_->qpos[q + 5] = 0.0;
  d_->qpos[q + 6] = std::sin(0.5 * yaw_rad);
  for (int i = 0; i < 6; ++i) d_->qvel[cube_dof_[k] + i] = 0.0;
  m_->geom_contype[cube_geom_[k]] = geom_contype_[k];
  m_->geom_conaffinity[cube_geom_[k]] = geom_conaffinity_[k];
  active_[k] = 1;
  for (Arm& a : arms_) {
    if (a.mode == Mode::kMirror) apply_mirror_pose(a);
  }
  if (Status st = forward(); !st) {
    park(k);
    return st.error();
  }
  return this->cube(k).value();
}

Status Simulation::show_pattern(bool on) {
  if (pattern_geom_ < 0) {
    return sim_error(
        SimError::kBadArgument,
        "show_pattern: this model has no pattern (build it with MjcfOptions::pattern)");
  }
  // a static, visual-only geom: moving it in the model is enough (parked 10 m aside, out of
  // every view, like the unused cubes)
  double* pos = m_->geom_pos + 3 * pattern_geom_;
  for (int i = 0; i < 3; ++i) pos[i] = pattern_pos_[i] + (on || i != 0 ? 0.0 : 10.0);
  pattern_shown_ = on;
  return forward();
}

void Simulation::reset_scene() {
  for (int r = 0; r < robot_count(); ++r) release(r);
  for (std::size_t k = 0; k < active_.size(); ++k) park(static_cast<int>(k));
  (void)forward();
}

Result<CubeState> Simulation::cube(int id) const {
  if (id < 0 || id >= static_cast<int>(active_.size()) || !active_[id]) {
    return sim_error(SimError::kNoSuchCube,
                     fmt::format("no cube with id {} in the scene ({} in the pool, ids 0..{})", id,
                                 active_.size(), active_.size() - 1));
  }
  CubeState s;
  s.id = id;
  s.color = CubeColor(id / pool_per_color_);
  const double* p = d_->qpos + cube_qpos_[id];
  s.pos_m = {p[0], p[1], p[2]};
  s.quat_wxyz = {p[3], p[4], p[5], p[6]};
  s.held = holder_of(id) >= 0;
  return s;
}

std::vector<CubeState> Simulation::cubes() const {
  std::vector<CubeState> out;
  for (std::size_t k = 0; k < active_.size(); ++k) {
    if (active_[k]) out.push_back(cube(static_cast<int>(k)).value());
  }
  return out;
}

int Simulation::cube_between_fingers(int robot) const {
  const Arm& a = arm(robot);
  const GripperGeometry g = gripper_geometry(a.robot);
  const double cube = workcell_.scene.cube_size_m;
  // the detector: the volume the open fingers enclose around the grasp point
  const double half_x = 0.5 * (g.closed_gap_m + 2 * g.open_travel_m) - 0.5 * cube + 0.001;
  const double half_y = 0.5 * g.finger_depth_m + 0.004;
  const double half_z = 0.5 * cube;
  const double* tp = d_->site_xpos + 3 * a.tool_site;
  const double* tr = d_->site_xmat + 9 * a.tool_site;
  int best = -1;
  double best_d = INFINITY;
  for (std::size_t k = 0; k < active_.size(); ++k) {
    if (!active_[k]) continue;
    // a cube another robot holds is not this one's to take
    const int holder = holder_of(static_cast<int>(k));
    if (holder >= 0 && holder != robot) continue;
    const double* p = d_->qpos + cube_qpos_[k];
    const mjtNum diff[3] = {p[0] - tp[0], p[1] - tp[1], p[2] - tp[2]};
    mjtNum local[3];
    mju_rotVecMatT(local, diff, tr);
    if (std::abs(local[0]) > half_x || std::abs(local[1]) > half_y || std::abs(local[2]) > half_z) {
      continue;
    }
    const double dist = mju_norm3(local);
    if (dist < best_d) {
      best_d = dist;
      best = static_cast<int>(k);
    }
  }
  return best;
}

void Simulation::set_fingers(Arm& a, bool closed) {
  a.gripper_closed = closed;
  if (a.mode == Mode::kMirror) apply_mirror_pose(a);
}

GraspResult Simulation::grip(int robot) {
  Arm& a = arm(robot);
  if (a.held >= 0) return GraspResult{true, a.held};
  set_fingers(a, true);
  const int k = cube_between_fingers(robot);
  if (k < 0) return GraspResult{false, -1};
  // the weld's relative pose from the current poses, so that the cube does not jump:
  // data = anchor (3, on the cube), pose of the cube in the gripper frame (3 + 4), torquescale
  const int b1 = a.gripper_body;
  const double* p1 = d_->xpos + 3 * b1;
  const double* r1 = d_->xmat + 9 * b1;
  const double* q1 = d_->xquat + 4 * b1;
  const double* p2 = d_->qpos + cube_qpos_[k];
  const double* q2 = p2 + 3;
  mjtNum* data = m_->eq_data + mjNEQDATA * a.cube_weld[k];
  const mjtNum diff[3] = {p2[0] - p1[0], p2[1] - p1[1], p2[2] - p1[2]};
  data[0] = data[1] = data[2] = 0.0;
  mju_rotVecMatT(data + 3, diff, r1);
  mjtNum q1_inv[4];
  mju_negQuat(q1_inv, q1);
  mju_mulQuat(data + 6, q1_inv, q2);
  data[10] = 1.0;
  a.held = k;
  // in simulate mode the weld holds the cube with dynamics; in mirror mode the robot is
  // kinematic (its joints are overwritten every step), so the cube is carried kinematically
  m_->eq_active[a.cube_weld[k]] = a.mode == Mode::kSimulate ? 1 : 0;
  return GraspResult{true, k};
}

void Simulation::carry_held_cube(Arm& a) {
  if (a.held < 0 || a.mode != Mode::kMirror) return;
  const int b1 = a.gripper_body;
  const mjtNum* data = m_->eq_data + mjNEQDATA * a.cube_weld[a.held];
  mjtNum* p2 = d_->qpos + cube_qpos_[a.held];
  mju_rotVecMat(p2, data + 3, d_->xmat + 9 * b1);
  for (int i = 0; i < 3; ++i) p2[i] += d_->xpos[3 * b1 + i];
  mju_mulQuat(p2 + 3, d_->xquat + 4 * b1, data + 6);
  mju_normalize4(p2 + 3);
  for (int i = 0; i < 6; ++i) d_->qvel[cube_dof_[a.held] + i] = 0.0;
}

void Simulation::release(int robot) {
  Arm& a = arm(robot);
  set_fingers(a, false);
  if (a.held >= 0) {
    m_->eq_active[a.cube_weld[a.held]] = 0;
    a.held = -1;
  }
}

}  // namespace scaratwin::sim
