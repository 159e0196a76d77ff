// The running virtual robot: a Simulation stepped by its own thread, paced to real time (or
// faster), behind a small thread-safe API. The TCP server (server.hpp) and the browser UI read
// and command the same World from their own threads:
//   - snapshot(): a consistent copy of what a viewer needs (joints, tool, cubes, tool path,
//     joint warnings, body poses), cheap enough for a 60 Hz feed;
//   - geometry(): the static shapes of the scene, once, to build a 3D view;
//   - with_simulation(f): runs f(Simulation&) under the lock, for commands;
//   - shoot(): a camera picture, rendering outside the lock.
#pragma once

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "scaratwin/core/result.hpp"
#include "scaratwin/sim/camera.hpp"
#include "scaratwin/sim/simulation.hpp"

namespace scaratwin::sim {

struct WorldOptions {
  // Simulated seconds per wall-clock second. 0 = as fast as possible while a trajectory runs
  // (prediction), real time otherwise (so that an idle server does not spin a core).
  double speed = 1.0;
  bool camera = true;  // create the offscreen camera (EGL); off for physics-only use
  RenderOptions render;
  int png_level = 1;  // zlib level of shot PNGs
};

// Pose of one MuJoCo body in B.
struct BodyPose {
  std::array<double, 3> pos_m{};
  std::array<double, 4> quat_wxyz{1, 0, 0, 0};
};

// One robot of the workcell as a viewer needs it.
struct RobotSnapshot {
  std::string name;
  Mode mode = Mode::kMirror;
  JointVector joints{};   // measured
  JointVector targets{};  // commanded now
  ToolPose tool;          // in the world frame
  bool gripper_closed = false;
  int held_cube = -1;
  bool trajectory_active = false;
};

// The fields without a robot are robot 0's (the paper's robot); `robots` has every robot of
// the workcell, robot 0 first.
struct Snapshot {
  std::uint64_t steps = 0;  // physics steps taken so far
  double time_s = 0.0;      // simulation time
  Mode mode = Mode::kMirror;
  JointVector joints{};   // measured
  JointVector targets{};  // commanded now
  ToolPose tool;
  bool gripper_closed = false;
  int held_cube = -1;
  bool trajectory_active = false;
  std::vector<CubeState> cubes;
  std::vector<ToolPoint> tool_path;           // oldest first
  std::vector<JointWarning> recent_warnings;  // oldest first
  std::uint64_t warnings_total = 0;
  std::vector<BodyPose> bodies;   // indexed like SceneGeometry::bodies
  double real_time_factor = 0.0;  // measured over the last second of stepping
  bool paused = false;
  std::vector<RobotSnapshot> robots;
  int arm_touches = 0;  // times two arms touched (a workcell of several robots)
};

// Static shapes of the scene for a 3D view. Geom poses are relative to their body.
struct GeomShape {
  std::string type;  // "box" (size = half extents), "capsule" / "cylinder" (radius, half
                     // length), "sphere" (radius), "plane"
  int body = 0;      // index into SceneGeometry::bodies
  std::array<double, 3> size{};
  std::array<double, 3> pos_m{};
  std::array<double, 4> quat_wxyz{1, 0, 0, 0};
  std::array<float, 4> rgba{};
};
struct SceneGeometry {
  std::vector<std::string> bodies;  // body names ("world", "carriage", ..., "cube_red_0")
  std::vector<GeomShape> geoms;
  std::string camera_name;  // the overhead camera, see RobotModel::scene.camera
};

class World {
 public:
  static Result<std::unique_ptr<World>> create(const RobotModel& robot,
                                               const SimOptions& sim_options = {},
                                               const WorldOptions& options = {});
  // A workcell of one or more robots (Simulation::create(Workcell)). With speed 0, the
  // simulation runs as fast as possible while any robot plays a trajectory, and never past the
  // last target of any robot's stream.
  static Result<std::unique_ptr<World>> create(const Workcell& workcell,
                                               const SimOptions& sim_options = {},
                                               const WorldOptions& options = {});
  ~World();  // stops the stepping thread
  World(const World&) = delete;
  World& operator=(const World&) = delete;

  // Starts / stops the stepping thread (idempotent). Before start() nothing moves by itself.
  void start();
  void stop();
  // While paused the thread takes no steps (tests, inspection).
  void set_paused(bool paused);

  Snapshot snapshot() const;
  SceneGeometry geometry() const;
  // Robot 0's description (its scene: the workcell's), and the whole workcell.
  const RobotModel& robot() const { return robot_; }
  const Workcell& workcell() const { return workcell_; }
  int robot_count() const { return static_cast<int>(workcell_.robots.size()); }
  const WorldOptions& options() const { return options_; }

  // Runs f(Simulation&) with the simulation locked; returns what f returns.
  template <typename F>
  auto with_simulation(F&& f) {
    std::lock_guard lock(mutex_);
    return f(*sim_);
  }

  // A picture of the overhead camera at width x height (0 x 0: the robot description's size),
  // and as PNG bytes. Errors: no camera, size beyond the offscreen buffer, render failure.
  Result<Image> shoot(int width_px = 0, int height_px = 0);
  Result<std::vector<std::uint8_t>> shoot_png(int width_px = 0, int height_px = 0);
  bool has_camera() const { return camera_ != nullptr; }
  int max_image_width_px() const;
  int max_image_height_px() const;

 private:
  World() = default;
  void run();

  RobotModel robot_;
  Workcell workcell_;
  WorldOptions options_;
  mutable std::mutex mutex_;  // guards sim_ and the counters below
  std::unique_ptr<Simulation> sim_;
  std::unique_ptr<Camera> camera_;
  std::uint64_t steps_ = 0;
  double rtf_ = 0.0;

  std::mutex run_mutex_;
  std::condition_variable wake_;
  std::atomic<bool> running_{false};
  std::atomic<bool> paused_{false};
  std::thread thread_;
};

}  // namespace scaratwin::sim
