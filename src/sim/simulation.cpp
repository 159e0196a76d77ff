// Simulation: model compilation, arm-arm contacts, stepping and state queries. Motion
// (mirror and simulate) is in motion.cpp, scene operations and the gripper in scene.cpp.
#include "scaratwin/sim/simulation.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>

#include <fmt/format.h>
#include <mujoco/mujoco.h>

#include "mj_guard.hpp"
#include "scaratwin/sim/camera.hpp"
#include "scaratwin/vision/webcam.hpp"
#include "sim_internal.hpp"

namespace scaratwin::sim {

using detail::sample;
using detail::sim_error;

int implausible_joint(const RobotModel& robot, const JointVector& q) {
  for (int j = 0; j < kNumJoints; ++j) {
    const JointLimit& l = robot.limits[static_cast<std::size_t>(j)];
    const double span = l.max - l.min;
    const double v = q[static_cast<std::size_t>(j)];
    if (!std::isfinite(v) || v < l.min - span || v > l.max + span) return j;
  }
  return -1;
}

const char* mode_name(Mode mode) { return mode == Mode::kMirror ? "mirror" : "simulate"; }

Simulation::~Simulation() {
  if (d_ != nullptr) mj_deleteData(d_);
  if (m_ != nullptr) mj_deleteModel(m_);
}

Result<std::unique_ptr<Simulation>> Simulation::create(const RobotModel& robot,
                                                       const SimOptions& options) {
  if (Status v = validate(robot); !v) return sim_error(SimError::kBadArgument, v.error().message);
  return create(single_robot_workcell(robot), options);
}

Result<std::unique_ptr<Simulation>> Simulation::create(const Workcell& workcell,
                                                       const SimOptions& options) {
  std::unique_ptr<Simulation> s(new Simulation());
  if (Status st = s->init(workcell, options); !st) return st.error();
  return s;
}

const Simulation::Arm& Simulation::arm(int robot) const {
  SCARATWIN_CHECK(robot >= 0 && robot < static_cast<int>(arms_.size()),
                  "robot index out of range (check_robot() first)");
  return arms_[static_cast<std::size_t>(robot)];
}

Simulation::Arm& Simulation::arm(int robot) {
  return const_cast<Arm&>(static_cast<const Simulation*>(this)->arm(robot));
}

Status Simulation::check_robot(int robot) const {
  if (robot >= 0 && robot < static_cast<int>(arms_.size())) return Ok{};
  return sim_error(SimError::kNoRobot,
                   fmt::format("no robot {} in this simulation: it has {} ({}, indices 0..{})",
                               robot, arms_.size(), robot_names(workcell_), arms_.size() - 1));
}

Status Simulation::init(const Workcell& workcell, const SimOptions& options) {
  if (Status v = validate(workcell); !v) {
    return sim_error(SimError::kBadArgument, v.error().message);
  }
  if (options.tool_path_points == 0 || !(options.tool_path_dt_s > 0.0)) {
    return sim_error(SimError::kBadArgument, "tool_path_points must be > 0 and tool_path_dt_s > 0");
  }
  workcell_ = workcell;
  options_ = options;
  auto xml = make_mjcf(workcell, options.mjcf);
  if (!xml) return sim_error(SimError::kBadArgument, xml.error().message);
  mjcf_ = std::move(*xml);
  pool_per_color_ = options.mjcf.cubes_per_color;

  // the printed pattern's texture, drawn from the description
  std::vector<std::uint8_t> pattern_png;
  if (options.mjcf.pattern) {
    auto sheet = pattern_sheet(workcell.scene.pattern);
    if (!sheet) return sim_error(SimError::kBadArgument, sheet.error().message);
    auto png = encode_png(Image{sheet->image.width, sheet->image.height, sheet->image.rgb});
    if (!png) return png.error();
    pattern_png = std::move(*png);
  }

  // compile from memory through a virtual file system
  auto vfs = std::make_unique<mjVFS>();
  char err[1024] = {0};
  struct Load {
    mjVFS* vfs;
    const std::string* xml;
    const std::vector<std::uint8_t>* texture;
    char* err;
    mjModel* m = nullptr;
    bool add(const char* name, const void* data, std::size_t size) {
      if (mj_makeEmptyFileVFS(vfs, name, static_cast<int>(size)) != 0) return false;
      std::memcpy(vfs->filedata[mj_findFileVFS(vfs, name)], data, size);
      return true;
    }
    void operator()() {
      mj_defaultVFS(vfs);
      if (add("scaratwin.xml", xml->data(), xml->size()) &&
          (texture->empty() || add(kPatternTextureFile, texture->data(), texture->size()))) {
        m = mj_loadXML("scaratwin.xml", vfs, err, 1024);
      }
      mj_deleteVFS(vfs);
    }
  } load{vfs.get(), &mjcf_, &pattern_png, err};
  if (Status st =
          detail::mj_guarded(static_cast<int>(SimError::kMujoco), "compiling the model", load);
      !st) {
    return st.error();
  }
  if (load.m == nullptr) {
    return sim_error(SimError::kMujoco, fmt::format("compiling the model: {}", err));
  }
  m_ = load.m;
  struct Make {
    mjModel* m;
    mjData* d = nullptr;
    void operator()() { d = mj_makeData(m); }
  } make{m_};
  if (Status st = detail::mj_guarded(static_cast<int>(SimError::kMujoco), "mj_makeData", make);
      !st) {
    return st.error();
  }
  d_ = make.d;
  if (d_ == nullptr) return sim_error(SimError::kMujoco, "mj_makeData: out of memory");

  const auto id = [&](mjtObj type, const std::string& name) {
    const int i = mj_name2id(m_, type, name.c_str());
    SCARATWIN_CHECK(i >= 0, "generated model lacks a named element");
    return i;
  };
  const int n = kNumColors * pool_per_color_;
  for (int k = 0; k < n; ++k) {
    const std::string name = cube_body_name(CubeColor(k / pool_per_color_), k % pool_per_color_);
    const int b = id(mjOBJ_BODY, name);
    cube_body_.push_back(b);
    cube_qpos_.push_back(m_->jnt_qposadr[m_->body_jntadr[b]]);
    cube_dof_.push_back(m_->jnt_dofadr[m_->body_jntadr[b]]);
    cube_geom_.push_back(m_->body_geomadr[b]);
    geom_contype_.push_back(m_->geom_contype[m_->body_geomadr[b]]);
    geom_conaffinity_.push_back(m_->geom_conaffinity[m_->body_geomadr[b]]);
  }
  // each robot's elements: unprefixed for a single robot (the robot's own model), "<name>/"
  // before each name with more (make_mjcf(Workcell))
  static constexpr const char* kJ[] = {"j1", "j2", "j3", "j4"};
  const bool prefixed = workcell.robots.size() > 1;
  for (const RobotInstance& r : workcell.robots) {
    const std::string pre = prefixed ? r.name + "/" : std::string();
    Arm a;
    a.name = r.name;
    a.base = r.base;
    a.robot = r.model;
    a.robot.scene = workcell.scene;
    for (int j = 0; j < kNumJoints; ++j) {
      const int jid = id(mjOBJ_JOINT, pre + kJ[j]);
      a.qpos[j] = m_->jnt_qposadr[jid];
      a.dof[j] = m_->jnt_dofadr[jid];
      a.actuator[j] = id(mjOBJ_ACTUATOR, pre + kJ[j]);
    }
    for (int f = 0; f < 2; ++f) {
      const int jid = id(mjOBJ_JOINT, pre + kFingerJoints[f]);
      a.finger_qpos[f] = m_->jnt_qposadr[jid];
      a.finger_dof[f] = m_->jnt_dofadr[jid];
      a.actuator[kNumJoints + f] = id(mjOBJ_ACTUATOR, pre + kFingerJoints[f]);
    }
    a.tool_site = id(mjOBJ_SITE, pre + kToolSite);
    a.gripper_body = id(mjOBJ_BODY, pre + kGripperBody);
    for (int k = 0; k < n; ++k) {
      const std::string name = cube_body_name(CubeColor(k / pool_per_color_), k % pool_per_color_);
      a.cube_weld.push_back(id(mjOBJ_EQUALITY, pre + "hold_" + name));
    }
    a.target = a.robot.home;
    arms_.push_back(std::move(a));
  }
  active_.assign(n, 0);
  for (int k = 0; k < n; ++k) park(k);
  if (options.mjcf.pattern) {
    pattern_geom_ = id(mjOBJ_GEOM, kPatternGeom);
    for (int i = 0; i < 3; ++i) pattern_pos_[i] = m_->geom_pos[3 * pattern_geom_ + i];
    pattern_shown_ = true;
  }
  setup_arm_collisions();
  for (Arm& a : arms_) apply_mirror_pose(a);
  return forward();
}

// Robot i's arm geoms (those that collide with nothing in the single robot's model: the
// column and the links) get contype bit i+1 and an affinity for every other robot's bit, so
// two arms collide and an arm never with itself, the table or the cubes (bit 0).
void Simulation::setup_arm_collisions() {
  const int n = robot_count();
  if (n < 2) return;
  constexpr int kMaxArms = 30;  // one contype bit each, bit 0 being the scene's
  std::vector<int> base_body;
  for (const Arm& a : arms_) {
    base_body.push_back(mj_name2id(m_, mjOBJ_BODY, (a.name + "/base_frame").c_str()));
  }
  geom_robot_.assign(static_cast<std::size_t>(m_->ngeom), -1);
  for (int g = 0; g < m_->ngeom; ++g) {
    for (int b = m_->geom_bodyid[g]; b > 0; b = m_->body_parentid[b]) {
      const auto it = std::find(base_body.begin(), base_body.end(), b);
      if (it != base_body.end()) {
        geom_robot_[g] = static_cast<int>(it - base_body.begin());
        break;
      }
    }
    const int r = geom_robot_[g];
    if (r < 0 || r >= kMaxArms || m_->geom_contype[g] != 0 || m_->geom_conaffinity[g] != 0) {
      continue;
    }
    int others = 0;
    for (int o = 0; o < std::min(n, kMaxArms); ++o) {
      if (o != r) others |= 1 << (o + 1);
    }
    m_->geom_contype[g] = 1 << (r + 1);
    m_->geom_conaffinity[g] = others;
  }
  touching_.assign(static_cast<std::size_t>(n * n), 0);
}

void Simulation::note_arm_contacts() {
  if (geom_robot_.empty()) return;
  const int n = robot_count();
  std::vector<char> now(touching_.size(), 0);
  for (int c = 0; c < d_->ncon; ++c) {
    int a = geom_robot_[d_->contact[c].geom1];
    int b = geom_robot_[d_->contact[c].geom2];
    if (a < 0 || b < 0 || a == b) continue;
    if (a > b) std::swap(a, b);
    now[static_cast<std::size_t>(a * n + b)] = 1;
  }
  for (int a = 0; a < n; ++a) {
    for (int b = a + 1; b < n; ++b) {
      const auto k = static_cast<std::size_t>(a * n + b);
      if (now[k] && !touching_[k]) {
        ++arm_contacts_.count;
        arm_contacts_.robot_a = a;
        arm_contacts_.robot_b = b;
        arm_contacts_.t_s = d_->time;
      }
    }
  }
  touching_ = std::move(now);
}

Result<std::unique_ptr<Simulation>> Simulation::clone() const {
  std::unique_ptr<Simulation> s(new Simulation());
  struct Copy {
    const mjModel* src_m;
    const mjData* src_d;
    mjModel* m = nullptr;
    mjData* d = nullptr;
    void operator()() {
      m = mj_copyModel(nullptr, src_m);
      d = mj_makeData(m);
      mj_copyData(d, m, src_d);
    }
  } copy{m_, d_};
  if (Status st =
          detail::mj_guarded(static_cast<int>(SimError::kMujoco), "copying the simulation", copy);
      !st) {
    return st.error();
  }
  s->m_ = copy.m;
  s->d_ = copy.d;
  s->workcell_ = workcell_;
  s->options_ = options_;
  s->mjcf_ = mjcf_;
  s->arms_ = arms_;
  s->geom_robot_ = geom_robot_;
  s->touching_ = touching_;
  s->arm_contacts_ = arm_contacts_;
  s->pool_per_color_ = pool_per_color_;
  s->cube_body_ = cube_body_;
  s->cube_qpos_ = cube_qpos_;
  s->cube_dof_ = cube_dof_;
  s->cube_geom_ = cube_geom_;
  s->active_ = active_;
  s->geom_contype_ = geom_contype_;
  s->geom_conaffinity_ = geom_conaffinity_;
  s->pattern_geom_ = pattern_geom_;
  s->pattern_pos_ = pattern_pos_;
  s->pattern_shown_ = pattern_shown_;
  s->warnings_ = warnings_;
  s->warnings_total_ = warnings_total_;
  return s;
}

Status Simulation::forward() {
  struct Fwd {
    const mjModel* m;
    mjData* d;
    void operator()() { mj_forward(m, d); }
  } fwd{m_, d_};
  return detail::mj_guarded(static_cast<int>(SimError::kMujoco), "mj_forward", fwd);
}

Status Simulation::step(int n) {
  if (n <= 0) return Ok{};
  // a light copy of the state, restored if MuJoCo fails part way
  const std::vector<double> qpos(d_->qpos, d_->qpos + m_->nq);
  const std::vector<double> qvel(d_->qvel, d_->qvel + m_->nv);
  const double time = d_->time;
  struct Steps {
    Simulation* s;
    int n;
    void operator()() {
      auto& arms = s->arms_;
      for (int i = 0; i < n; ++i) {
        for (std::size_t r = 0; r < arms.size(); ++r) {
          if (arms[r].mode == Mode::kMirror) {
            s->apply_mirror_pose(arms[r]);
          } else {
            s->run_due_gripper_events(static_cast<int>(r));
            s->apply_simulate_controls(arms[r]);
          }
        }
        mj_step(s->m_, s->d_);
        s->note_arm_contacts();
        for (Arm& a : arms) {
          if (a.mode == Mode::kMirror) s->apply_mirror_pose(a);
        }
        for (std::size_t k = 0; k < s->active_.size(); ++k) {
          if (!s->active_[k]) s->park(static_cast<int>(k));
        }
        // poses for the carried cubes, the tool paths and the callers; mj_step recomputes
        // everything from qpos, so skipping this on other steps changes no result
        const bool last = i + 1 == n;
        bool carry = false, path_due = false;
        for (const Arm& a : arms) {
          carry = carry || (a.held >= 0 && a.mode == Mode::kMirror);
          path_due = path_due || s->d_->time + 1e-12 >= a.next_path_s;
        }
        if (last || carry || path_due) mj_kinematics(s->m_, s->d_);
        for (Arm& a : arms) {
          s->carry_held_cube(a);
          s->record_tool_path(a);
        }
      }
    }
  } steps{this, n};
  Status st = detail::mj_guarded(static_cast<int>(SimError::kMujoco), "mj_step", steps);
  if (!st) {
    mj_resetData(m_, d_);
    std::copy(qpos.begin(), qpos.end(), d_->qpos);
    std::copy(qvel.begin(), qvel.end(), d_->qvel);
    d_->time = time;
    (void)forward();
  }
  return st;
}

Status Simulation::step_until(double t_s) {
  const double dt = timestep_s();
  const double remaining = t_s - d_->time;
  if (!(remaining > 0.0)) return Ok{};
  const int n = static_cast<int>(std::ceil(remaining / dt - 1e-9));
  return step(std::max(n, 0));
}

double Simulation::time_s() const { return d_->time; }
double Simulation::timestep_s() const { return m_->opt.timestep; }

JointVector Simulation::joints(int robot) const {
  const Arm& a = arm(robot);
  JointVector q{};
  for (int j = 0; j < kNumJoints; ++j) q[j] = d_->qpos[a.qpos[j]];
  return q;
}

JointVector Simulation::joint_targets(int robot) const {
  const Arm& a = arm(robot);
  if (a.mode == Mode::kSimulate && a.traj) {
    JointVector q{}, qd{};
    std::size_t hint = 0;
    sample(a.traj->trajectory, d_->time - a.traj->start_s, hint, q, qd);
    return q;
  }
  return a.target;
}

std::array<double, 3> Simulation::tool_site_pos(int robot) const {
  const double* p = d_->site_xpos + 3 * arm(robot).tool_site;
  return {p[0], p[1], p[2]};
}

ToolPose Simulation::tool_pose(int robot) const {
  const auto p = tool_site_pos(robot);
  const double* r = d_->site_xmat + 9 * arm(robot).tool_site;
  return ToolPose{p[0], p[1], p[2], std::atan2(r[3], r[0])};
}

std::vector<ToolPoint> Simulation::tool_path(int robot) const {
  const Arm& a = arm(robot);
  return {a.path.begin(), a.path.end()};
}

}  // namespace scaratwin::sim
