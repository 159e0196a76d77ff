// The control statements from C++: connect to a running simulator and robot, home, spawn a
// cube in the virtual scene, read its position back (func_point), move the physical robot to
// it and put it into its tray while the virtual robot follows, then take a picture.
//
//   pick_one SERIAL_DEVICE SIM_PORT [PICTURE.png]
#include <cstdio>
#include <cstdlib>
#include <fstream>

#include "scaratwin/config/robot_config.hpp"
#include "scaratwin/hub/hub.hpp"
#include "scaratwin/hub/tasks.hpp"

int main(int argc, char** argv) {
  using namespace scaratwin;
  if (argc < 3) {
    std::fprintf(stderr, "usage: pick_one SERIAL_DEVICE SIM_PORT [PICTURE.png]\n");
    return 2;
  }
  auto model = load_robot_config_or_default({});
  if (!model) {
    std::fprintf(stderr, "%s\n", model.error().message.c_str());
    return 2;
  }
  HubOptions options;
  options.serial_device = argv[1];
  options.sim_port = static_cast<std::uint16_t>(std::atoi(argv[2]));
  auto hub = Hub::connect(*model, options, nullptr);
  if (!hub) {
    std::fprintf(stderr, "connect: %s\n", hub.error().message.c_str());
    return 1;
  }
  Hub& h = **hub;
  h.set_mirror(true);
  const auto fail = [](const char* what, const Error& e) {
    std::fprintf(stderr, "%s: %s\n", what, e.message.c_str());
    return 1;
  };
  if (Status s = h.home(); !s) return fail("home", s.error());
  if (Status s = h.reset_scene(); !s) return fail("reset", s.error());
  auto id = h.spawn_cube(CubeColor::kGreen, 0.19, 0.07);
  if (!id) return fail("spawn", id.error());
  auto objects = h.objects();  // func_point
  if (!objects || objects->empty())
    return fail("objects", Error{ScriptError::kNoSuchCube, "no cube in the scene"});
  const protocol::ObjectPose cube = objects->front();
  std::printf("cube %d at (%.4f, %.4f, %.4f) m\n", cube.id, cube.x_m, cube.y_m, cube.z_m);
  auto now = h.fresh_physical(2.0);  // OperationMonitoring2
  if (!now) return fail("state", now.error());
  auto plan = plan_sorting(*model, now->q, {{cube.color, cube.x_m, cube.y_m, cube.yaw_rad}});
  if (!plan) return fail("plan", plan.error());
  auto points = h.run_trajectory(plan->trajectory);  // numberTran3
  if (!points) return fail("run", points.error());
  std::printf("%d points, %.1f s\n", *points, plan->trajectory.duration_s());
  auto after = h.objects();
  if (!after) return fail("objects", after.error());
  const int in_tray = cubes_in_trays(*model, *after);
  std::printf("cubes in their tray: %d\n", in_tray);
  if (argc > 3) {
    auto png = h.shoot();  // camera
    if (!png) return fail("shoot", png.error());
    std::ofstream(argv[3], std::ios::binary)
        .write(png->data(), static_cast<std::streamsize>(png->size()));
    std::printf("picture: %s (%zu bytes)\n", argv[3], png->size());
  }
  return in_tray == 1 ? 0 : 1;
}
