// bench_sim: how fast the virtual robot runs on one core.
//  - physics: real-time factor of the full sorting scene (three trays, cubes of every colour on
//    the table) while the robot runs pick-and-place trajectories with the servos (simulate
//    mode), with the robot idle, and in mirror mode; target >= 50x.
//  - camera: offscreen render + PNG encode at 640x480 through EGL/llvmpipe; target >= 30 fps.
// Prints a table; figures go to docs/benchmarks.md.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <string>
#include <vector>

#include <fmt/format.h>

#include "scaratwin/config/robot_config.hpp"
#include "scaratwin/core/units.hpp"
#include "scaratwin/sim/camera.hpp"
#include "scaratwin/sim/server.hpp"
#include "scaratwin/sim/simulation.hpp"
#include "scaratwin/sim/world.hpp"
#include "scaratwin/trajectory/trajectory.hpp"
#include "scaratwin/transport/tcp.hpp"

using namespace scaratwin;
using namespace scaratwin::sim;
using Clock = std::chrono::steady_clock;

namespace {

double since(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

// CPU time of this thread: on a shared machine the honest measure of "one core".
double thread_cpu_s() {
  timespec t{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
}

// The sorting scene: `per_color` cubes of each colour spread over the table in front of the
// robot.
std::unique_ptr<Simulation> sorting_scene(const RobotModel& robot, int per_color) {
  SimOptions o;
  o.mjcf.cubes_per_color = std::max(per_color, 1);
  auto sim = Simulation::create(robot, o);
  if (!sim) {
    std::fprintf(stderr, "bench_sim: %s\n", sim.error().message.c_str());
    std::exit(1);
  }
  int k = 0;
  for (int i = 0; i < per_color; ++i) {
    for (int c = 0; c < kNumColors; ++c, ++k) {
      const double x = 0.1 + 0.035 * (k % 5), y = 0.04 + 0.035 * (k / 5);
      if (!(*sim)->spawn_cube(CubeColor(c), x, y, 0.3 * k).ok()) std::exit(1);
    }
  }
  (void)(*sim)->step(250);  // settle
  return std::move(*sim);
}

// Pick-and-place trajectories over the scene's cubes, repeated.
JointTrajectory workload(const Simulation& sim) {
  const RobotModel& r = sim.robot();
  JointTrajectory all;
  all.samples.push_back({0.0, sim.joints(), {}, {}});
  for (const CubeState& c : sim.cubes()) {
    const Tray& tray = r.scene.trays[static_cast<int>(c.color)];
    for (int k = 0; k < 24; ++k) {
      PickPlaceRequest req;
      const double yaw = deg_to_rad(-180.0 + 15.0 * k);
      req.pick = {c.pos_m[0], c.pos_m[1], r.scene.grasp_z_m, yaw};
      req.place = {tray.x_m + 0.008, tray.y_m - 0.008, r.scene.grasp_z_m + 0.004, yaw};
      req.approach_height_m = r.scene.approach_height_m;
      auto t = plan_pick_place(r, all.samples.back().q, req);
      if (t) {
        append(all, *t);
        break;
      }
    }
  }
  return all;
}

struct PhysicsRow {
  std::string what;
  int cubes = 0;
  double sim_s = 0.0;
  double wall_s = 0.0;
  double cpu_s = 0.0;
  double dt_s = 0.0;
};

PhysicsRow run_physics(const RobotModel& robot, const std::string& what, int per_color,
                       double sim_seconds, int kind) {
  auto sim = sorting_scene(robot, per_color);
  if (kind == 0) {
    sim->set_mode(Mode::kSimulate);
    const JointTrajectory t = workload(*sim);
    if (!sim->follow(t).ok()) std::exit(1);
  } else if (kind == 1) {
    sim->set_mode(Mode::kSimulate);
  }
  const double t0 = sim->time_s();
  const auto w0 = Clock::now();
  const double c0 = thread_cpu_s();
  int frame = 0;
  while (sim->time_s() - t0 < sim_seconds) {
    if (kind == 2) {
      // mirror: a joint frame every 5 ms, as a 200 Hz state stream would bring
      const double s = 0.3 * std::sin(0.5 * frame * 0.005);
      if (!sim->set_joints({0.1, s, -s, 0.5}).ok()) std::exit(1);
      ++frame;
    }
    if (!sim->step(kind == 2 ? std::max(1, static_cast<int>(0.005 / sim->timestep_s() + 0.5)) : 50)
             .ok()) {
      std::exit(1);
    }
  }
  return {what,
          static_cast<int>(sim->cubes().size()),
          sim->time_s() - t0,
          since(w0),
          thread_cpu_s() - c0,
          sim->timestep_s()};
}

}  // namespace

int main(int argc, char** argv) {
  double sim_seconds = 20.0;
  int frames = 120;
  int per_color = 3;
  for (int i = 1; i + 1 < argc; i += 2) {
    if (!std::strcmp(argv[i], "--sim-seconds")) sim_seconds = std::atof(argv[i + 1]);
    if (!std::strcmp(argv[i], "--frames")) frames = std::atoi(argv[i + 1]);
    if (!std::strcmp(argv[i], "--cubes-per-color")) per_color = std::atoi(argv[i + 1]);
  }
  auto robot = load_robot_config_or_default("");
  if (!robot) {
    std::fprintf(stderr, "bench_sim: %s\n", robot.error().message.c_str());
    return 1;
  }

  std::puts("physics (one thread; real-time factor = simulated s / CPU s of the thread)");
  std::puts(
      "| scene | cubes | dt ms | sim s | CPU s | wall s | steps/s | real-time factor | target |");
  std::puts("|---|---|---|---|---|---|---|---|---|");
  const PhysicsRow rows[] = {
      run_physics(*robot, "sorting, pick-and-place (simulate)", per_color, sim_seconds, 0),
      run_physics(*robot, "sorting, robot holding (simulate)", per_color, sim_seconds, 1),
      run_physics(*robot, "sorting, 200 Hz joint frames (mirror)", per_color, sim_seconds, 2),
  };
  for (const PhysicsRow& r : rows) {
    fmt::print("| {} | {} | {:.0f} | {:.1f} | {:.3f} | {:.3f} | {:.0f} | {:.1f}x | >= 50x |\n",
               r.what, r.cubes, 1e3 * r.dt_s, r.sim_s, r.cpu_s, r.wall_s,
               r.sim_s / r.dt_s / r.cpu_s, r.sim_s / r.cpu_s);
  }

  auto sim = sorting_scene(*robot, per_color);
  (void)sim->set_joints({0.12, deg_to_rad(100.0), deg_to_rad(-40.0), 0.5});
  std::puts("\ncamera 640x480 (EGL surfaceless, llvmpipe; PNG zlib level 1, up filter)");
  std::puts("| variant | render ms | encode ms | PNG KiB | frames/s (render + encode) | target |");
  std::puts("|---|---|---|---|---|---|");
  for (bool shadows : {false, true}) {
    auto cam = Camera::create(*sim, {shadows});
    if (!cam) {
      std::fprintf(stderr, "bench_sim: %s\n", cam.error().message.c_str());
      return 1;
    }
    (void)(*cam)->render(*sim, 640, 480);  // warm up
    double render_s = 0, encode_s = 0;
    std::size_t bytes = 0;
    const auto w0 = Clock::now();
    for (int i = 0; i < frames; ++i) {
      (void)sim->step(10);  // the scene changes between frames
      const auto r0 = Clock::now();
      auto img = (*cam)->render(*sim, 640, 480);
      render_s += since(r0);
      if (!img) return 1;
      const auto e0 = Clock::now();
      auto png = encode_png(*img, 1);
      encode_s += since(e0);
      if (!png) return 1;
      bytes += png->size();
    }
    (void)since(w0);
    fmt::print("| {} | {:.1f} | {:.1f} | {:.0f} | {:.1f} | >= 30 |\n",
               shadows ? "shadows" : "no shadows (default)", 1e3 * render_s / frames,
               1e3 * encode_s / frames, static_cast<double>(bytes) / 1024.0 / frames,
               frames / (render_s + encode_s));
  }

  // the server over loopback TCP: a joint frame in mirror mode (JD -> JA) and a camera shot
  // (CS -> IM + PNG), with the world stepping in real time beside it
  std::puts("\nserver over loopback TCP (world paced at 1x, 9 cubes)");
  std::puts("| request | count | p50 ms | p99 ms | mean ms |");
  std::puts("|---|---|---|---|---|");
  SimOptions so;
  so.mjcf.cubes_per_color = per_color;
  auto world = World::create(*robot, so);
  if (!world) return 1;
  ServerOptions srv;
  srv.port = 0;
  auto server = SimServer::create(**world, srv);
  if (!server) return 1;
  (*world)->start();
  transport::TcpClientOptions co;
  co.port = (*server)->port();
  auto client = transport::TcpClient::create(co);
  if (!client || !(*client)->wait_connected(transport::Duration(3000)).ok()) return 1;
  const auto measure = [&](const char* what, int count, const std::string& request) {
    std::vector<double> ms;
    for (int i = 0; i < count; ++i) {
      const auto t0 = Clock::now();
      if (!(*client)->send(request).ok()) std::exit(1);
      if (!(*client)->receive(transport::Duration(5000)).ok()) std::exit(1);
      ms.push_back(1e3 * since(t0));
    }
    std::sort(ms.begin(), ms.end());
    double sum = 0;
    for (double v : ms) sum += v;
    fmt::print("| {} | {} | {:.3f} | {:.3f} | {:.3f} |\n", what, count, ms[ms.size() / 2],
               ms[std::min(ms.size() - 1, ms.size() * 99 / 100)], sum / static_cast<double>(count));
  };
  for (int i = 0; i < per_color; ++i) {
    for (int c = 0; c < kNumColors; ++c) {
      const std::string sc = fmt::format("SC,{},{},{},\n", color_name(CubeColor(c)),
                                         100 + 35 * ((3 * i + c) % 5), 40 + 35 * ((3 * i + c) / 5));
      (void)(*client)->send(sc);
      (void)(*client)->receive(transport::Duration(5000));
    }
  }
  measure("JD -> JA (mirror joint frame)", 2000, "JD,1,0,80,20,-30,45,\n");
  measure("CS 640x480 -> IM + PNG", frames / 2, "CS,640,480,\n");
  (*client)->close();
  server->reset();
  (*world)->stop();
  return 0;
}
