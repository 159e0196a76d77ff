// bench_plant: how fast the physical robot as built (the emulator's plant) runs on one core,
// without the AVR: emulated seconds per CPU second of this thread, at rest (three cubes on the
// table, motors holding) and while the three steppers and the wrist move back and forth at
// the description's speed limit. Target (issue: the physical world): >= 20x real time. Also
// checks that two runs with the same seed give the same truth. Prints a table.
#include <cstdio>
#include <ctime>

#include <fmt/format.h>

#include "../../tests/plant/plant_driver.hpp"
#include "scaratwin/core/units.hpp"
#include "scaratwin/plant/plant.hpp"

using namespace scaratwin;

namespace {

double thread_cpu_s() {
  timespec t{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
}

std::unique_ptr<plant::Plant> make(const RobotModel& model) {
  AsBuiltProfile prof;
  prof.seed = 1;
  auto p = plant::Plant::create(model, draw_as_built(prof));
  if (!p) {
    std::fprintf(stderr, "bench_plant: %s\n", p.error().message.c_str());
    std::exit(1);
  }
  (void)(*p)->place_cube(CubeColor::kRed, 0.16, 0.06, 0.0);
  (void)(*p)->place_cube(CubeColor::kGreen, 0.21, 0.07, 0.0);
  (void)(*p)->place_cube(CubeColor::kBlue, 0.17, 0.11, 0.0);
  return std::move(p).value();
}

struct Figures {
  double sim_s = 0.0;
  double cpu_s = 0.0;
  JointVector final_q{};
};

Figures moving(const RobotModel& model, int cycles) {
  auto p = make(model);
  plant::testing::Driver d(*p);
  const double c0 = thread_cpu_s();
  for (int i = 0; i < cycles; ++i) {
    d.move_joints(model, {0.05, deg_to_rad(60), deg_to_rad(-80), deg_to_rad(90)}, 5000, 1500);
    d.move_joints(model, {0.11, deg_to_rad(-40), deg_to_rad(70), deg_to_rad(10)}, 5000, 1500);
  }
  return {d.time_s(), thread_cpu_s() - c0, p->joints()};
}

Figures resting(const RobotModel& model, double seconds) {
  auto p = make(model);
  plant::testing::Driver d(*p);
  const double c0 = thread_cpu_s();
  d.wait(seconds);
  return {d.time_s(), thread_cpu_s() - c0, p->joints()};
}

}  // namespace

int main(int argc, char** argv) {
  const int cycles = argc > 1 ? std::atoi(argv[1]) : 5;
  const RobotModel model = paper_robot();
  const Figures rest = resting(model, 20.0);
  const Figures move = moving(model, cycles);
  const Figures again = moving(model, cycles);
  fmt::print("| plant (as built, seed 1, 3 cubes) | emulated s | CPU s | x real time |\n");
  fmt::print("|---|---|---|---|\n");
  fmt::print("| at rest | {:.1f} | {:.2f} | {:.0f} |\n", rest.sim_s, rest.cpu_s,
             rest.sim_s / rest.cpu_s);
  fmt::print("| moving (Z, J2, J3, wrist at 5000 steps/s) | {:.1f} | {:.2f} | {:.0f} |\n",
             move.sim_s, move.cpu_s, move.sim_s / move.cpu_s);
  fmt::print("\nsame seed, same inputs, same truth: {}\n",
             move.final_q == again.final_q ? "yes (bit for bit)" : "NO");
  return move.final_q == again.final_q ? 0 : 1;
}
