// spawn_at_random: the scene's own spawn spot for a cube.
#include "scaratwin/sim/spawn.hpp"

#include <cmath>
#include <numbers>

#include <fmt/format.h>

#include "scaratwin/kinematics/kinematics.hpp"
#include "scaratwin/sim/camera.hpp"

namespace scaratwin::sim {

Result<CubeState> spawn_at_random(Simulation& sim, CubeColor color, std::mt19937_64& rng) {
  const RobotModel& robot = sim.robot();
  int in_use = 0;
  for (const CubeState& c : sim.cubes()) in_use += c.color == color ? 1 : 0;
  if (in_use >= sim.cubes_per_color()) {
    return Error{static_cast<int>(SimError::kPoolExhausted),
                 fmt::format("all {} {} cubes are in the scene: reset to remove them",
                             sim.cubes_per_color(), color_name(color))};
  }
  // candidates around the shoulder axis, inside the reach at grasp height, away from the
  // column and the trays, and in the camera's view (so the vision can find them)
  const double a1 = robot.dh[0].a_m;
  const double reach = robot.dh[1].a_m + robot.dh[2].a_m;
  const double cube = robot.scene.cube_size_m;
  std::uniform_real_distribution<double> radius(0.45 * reach, 0.92 * reach);
  std::uniform_real_distribution<double> angle(-0.5 * std::numbers::pi, 0.5 * std::numbers::pi);
  const CameraModel& cam = robot.scene.camera;
  for (int attempt = 0; attempt < 200; ++attempt) {
    const double r = radius(rng);
    const double a = angle(rng);
    const double x = a1 + r * std::cos(a);
    const double y = r * std::sin(a);
    if (std::hypot(x, y) < 0.06) continue;
    bool on_tray = false;
    for (const Tray& t : robot.scene.trays) {
      const double margin = 0.5 * t.size_m + cube;
      on_tray |= std::abs(x - t.x_m) < margin && std::abs(y - t.y_m) < margin;
    }
    if (on_tray) continue;
    const PixelPoint px =
        project(cam, cam.width_px, cam.height_px, {x, y, robot.scene.table_z_m + 0.5 * cube});
    const double edge = 0.05 * cam.width_px;
    if (!px.visible || px.u_px < edge || px.v_px < edge || px.u_px > cam.width_px - edge ||
        px.v_px > cam.height_px - edge) {
      continue;
    }
    bool reachable = false;
    for (double yaw : {0.0, 0.5 * std::numbers::pi, std::numbers::pi, -0.5 * std::numbers::pi}) {
      ToolPose pose;
      pose.x_m = x;
      pose.y_m = y;
      pose.z_m = robot.scene.grasp_z_m;
      pose.yaw_rad = yaw;
      if (inverse(robot, pose, robot.home)) {
        reachable = true;
        break;
      }
    }
    if (!reachable) continue;
    auto spawned = sim.spawn_cube(color, x, y);
    if (spawned) return spawned;
    if (spawned.error().code != static_cast<int>(SimError::kOccupied)) return spawned;
  }
  return Error{static_cast<int>(SimError::kOccupied),
               "no free spot found for a cube in 200 tries: remove some cubes"};
}

}  // namespace scaratwin::sim
