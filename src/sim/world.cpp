// World: the stepping thread with real-time pacing, snapshots and camera shots.
#include "scaratwin/sim/world.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>

#include <fmt/format.h>
#include <mujoco/mujoco.h>

namespace scaratwin::sim {
namespace {

using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

}  // namespace

Result<std::unique_ptr<World>> World::create(const RobotModel& robot, const SimOptions& sim_options,
                                             const WorldOptions& options) {
  if (Status v = validate(robot); !v) {
    return Error{static_cast<int>(SimError::kBadArgument), v.error().message};
  }
  return create(single_robot_workcell(robot), sim_options, options);
}

Result<std::unique_ptr<World>> World::create(const Workcell& workcell,
                                             const SimOptions& sim_options,
                                             const WorldOptions& options) {
  if (!(options.speed >= 0.0) || options.speed > 1e6) {
    return Error{static_cast<int>(SimError::kBadArgument),
                 fmt::format("speed {}: must be >= 0 (0 = as fast as possible)", options.speed)};
  }
  std::unique_ptr<World> w(new World());
  w->options_ = options;
  auto sim = Simulation::create(workcell, sim_options);
  if (!sim) return sim.error();
  w->sim_ = std::move(*sim);
  w->workcell_ = workcell;
  w->robot_ = w->sim_->robot(0);
  if (options.camera) {
    auto cam = Camera::create(*w->sim_, options.render);
    if (!cam) return cam.error();
    w->camera_ = std::move(*cam);
  }
  return w;
}

World::~World() { stop(); }

void World::start() {
  if (running_.exchange(true)) return;
  thread_ = std::thread([this] { run(); });
}

void World::stop() {
  if (!running_.exchange(false)) return;
  wake_.notify_all();
  if (thread_.joinable()) thread_.join();
}

void World::set_paused(bool paused) {
  paused_ = paused;
  wake_.notify_all();
}

void World::run() {
  // pacing: simulation time follows t_sim0 + speed * (wall - t_wall0); the origin is moved when
  // the simulation falls behind by more than a quarter second (no catch-up bursts) or pauses
  constexpr double kMaxLag_s = 0.25;
  constexpr int kFastChunk = 25;  // steps per lock in fast mode
  const double speed = options_.speed > 0.0 ? options_.speed : 1.0;
  auto wall0 = Clock::now();
  double sim0 = with_simulation([](Simulation& s) { return s.time_s(); });
  auto rtf_wall = Clock::now();
  double rtf_sim = sim0;
  while (running_) {
    if (paused_) {
      std::unique_lock lock(run_mutex_);
      wake_.wait_for(lock, std::chrono::milliseconds(20));
      wall0 = Clock::now();
      sim0 = with_simulation([](Simulation& s) { return s.time_s(); });
      continue;
    }
    double next_due_s = 0.0;
    {
      std::lock_guard lock(mutex_);
      const double dt = sim_->timestep_s();
      // --speed max: as fast as possible while any robot plays a trajectory, in lockstep with
      // the streams of targets (a robot's stream is never played past its last target)
      bool active = false;
      double horizon_s = INFINITY;
      for (int r = 0; r < sim_->robot_count(); ++r) {
        active = active || sim_->trajectory_active(r);
        if (sim_->stream_open(r)) horizon_s = std::min(horizon_s, sim_->stream_horizon_s(r));
      }
      const bool fast = options_.speed == 0.0 && active;
      Status st = Ok{};
      const std::uint64_t before_t = static_cast<std::uint64_t>(std::llround(sim_->time_s() / dt));
      if (fast && std::isfinite(horizon_s)) {
        // lockstep with the streams: up to the earliest last target, then wait for the next
        const double ahead = (horizon_s - sim_->time_s()) / dt + 1e-9;
        const int n = std::min(kFastChunk, static_cast<int>(std::max(0.0, std::floor(ahead))));
        st = sim_->step(n);
        if (n == 0) next_due_s = 0.001;
        wall0 = Clock::now();
        sim0 = sim_->time_s();
      } else if (fast) {
        st = sim_->step(kFastChunk);
        wall0 = Clock::now();
        sim0 = sim_->time_s();
      } else {
        double target = sim0 + speed * seconds_since(wall0);
        if (target - sim_->time_s() > kMaxLag_s) {
          wall0 = Clock::now();
          sim0 = sim_->time_s();
          target = sim0;
        }
        st = sim_->step_until(target);
        next_due_s = (sim_->time_s() + dt - target) / speed;
      }
      const std::uint64_t after_t = static_cast<std::uint64_t>(std::llround(sim_->time_s() / dt));
      steps_ += after_t - before_t;
      if (!st) std::fprintf(stderr, "scaratwin-sim: %s\n", st.error().message.c_str());
      const double wall = seconds_since(rtf_wall);
      if (wall >= 1.0) {
        rtf_ = (sim_->time_s() - rtf_sim) / wall;
        rtf_wall = Clock::now();
        rtf_sim = sim_->time_s();
      }
    }
    if (next_due_s > 0.0) {
      std::unique_lock lock(run_mutex_);
      wake_.wait_for(lock, std::chrono::duration<double>(std::min(next_due_s, 0.005)));
    } else {
      std::this_thread::yield();
    }
  }
}

Snapshot World::snapshot() const {
  std::lock_guard lock(mutex_);
  const Simulation& s = *sim_;
  Snapshot out;
  out.steps = steps_;
  out.time_s = s.time_s();
  out.mode = s.mode();
  out.joints = s.joints();
  out.targets = s.joint_targets();
  out.tool = s.tool_pose();
  out.gripper_closed = s.gripper_closed();
  out.held_cube = s.held_cube();
  out.trajectory_active = s.trajectory_active();
  out.cubes = s.cubes();
  out.tool_path = s.tool_path();
  out.recent_warnings.assign(s.recent_warnings().begin(), s.recent_warnings().end());
  out.warnings_total = s.warnings_total();
  out.arm_touches = s.arm_contacts().count;
  const mjModel* m = s.model();
  const mjData* d = s.data();
  out.bodies.resize(m->nbody);
  for (int b = 0; b < m->nbody; ++b) {
    for (int i = 0; i < 3; ++i) out.bodies[b].pos_m[i] = d->xpos[3 * b + i];
    for (int i = 0; i < 4; ++i) out.bodies[b].quat_wxyz[i] = d->xquat[4 * b + i];
  }
  out.real_time_factor = rtf_;
  out.paused = paused_;
  for (int r = 0; r < s.robot_count(); ++r) {
    out.robots.push_back(RobotSnapshot{s.robot_name(r), s.mode(r), s.joints(r), s.joint_targets(r),
                                       s.tool_pose(r), s.gripper_closed(r), s.held_cube(r),
                                       s.trajectory_active(r)});
  }
  return out;
}

SceneGeometry World::geometry() const {
  std::lock_guard lock(mutex_);
  const mjModel* m = sim_->model();
  SceneGeometry g;
  for (int b = 0; b < m->nbody; ++b) {
    const char* name = mj_id2name(m, mjOBJ_BODY, b);
    g.bodies.emplace_back(name != nullptr ? name : fmt::format("body{}", b));
  }
  for (int i = 0; i < m->ngeom; ++i) {
    GeomShape s;
    switch (m->geom_type[i]) {
      case mjGEOM_BOX:
        s.type = "box";
        break;
      case mjGEOM_CAPSULE:
        s.type = "capsule";
        break;
      case mjGEOM_CYLINDER:
        s.type = "cylinder";
        break;
      case mjGEOM_SPHERE:
        s.type = "sphere";
        break;
      case mjGEOM_PLANE:
        s.type = "plane";
        break;
      default:
        continue;
    }
    s.body = m->geom_bodyid[i];
    for (int k = 0; k < 3; ++k) {
      s.size[k] = m->geom_size[3 * i + k];
      s.pos_m[k] = m->geom_pos[3 * i + k];
    }
    for (int k = 0; k < 4; ++k) {
      s.quat_wxyz[k] = m->geom_quat[4 * i + k];
      s.rgba[k] = m->geom_rgba[4 * i + k];
    }
    g.geoms.push_back(s);
  }
  g.camera_name = kCameraName;
  return g;
}

int World::max_image_width_px() const { return camera_ ? camera_->max_width_px() : 0; }
int World::max_image_height_px() const { return camera_ ? camera_->max_height_px() : 0; }

Result<Image> World::shoot(int width_px, int height_px) {
  if (!camera_) {
    return Error{static_cast<int>(SimError::kRender), "this simulator runs without a camera"};
  }
  if (width_px == 0 && height_px == 0) {
    width_px = robot_.scene.camera.width_px;
    height_px = robot_.scene.camera.height_px;
  }
  {
    std::lock_guard lock(mutex_);
    if (Status st = camera_->capture(*sim_); !st) return st.error();
  }
  return camera_->draw(width_px, height_px);
}

Result<std::vector<std::uint8_t>> World::shoot_png(int width_px, int height_px) {
  auto img = shoot(width_px, height_px);
  if (!img) return img.error();
  return encode_png(*img, options_.png_level);
}

}  // namespace scaratwin::sim
