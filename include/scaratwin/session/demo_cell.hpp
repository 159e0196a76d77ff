// `scaratwin demo --robots N` (Python's scaratwin.demo with a workcell): N emulated robots on
// one table of one simulator, sorting the cubes together (docs/workcell.md "Two arms, one
// table").
#pragma once

#include <atomic>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <string>

#include "scaratwin/core/result.hpp"
#include "scaratwin/kinematics/workcell.hpp"
#include "scaratwin/session/say.hpp"

namespace scaratwin::session {

struct CellDemoOptions {
  std::filesystem::path out;  // exists; the databases, reports, results and logs go here
  int http_port = 8080;
  double robot_speed = 1.0;
  unsigned seed = 7;
  // Each robot is a robot as built (scaratwin-robot --plant as-built): robot i's build is drawn
  // with seed as_built_seed + i (-1: its description's [as_built] seed + i). `ideal`: the
  // exact robots (--plant ideal) instead.
  long long as_built_seed = -1;
  bool ideal = false;
  int cubes = 3;
  // set (by a signal handler) to stop every robot
  const std::atomic<bool>* interrupted = nullptr;
  // runs after the reports, while the simulator still runs (--keep-open waits there)
  std::function<void()> before_stop;
};

struct CellDemoResult {
  bool ok = false;  // every cube in its tray, no frame of any robot lost, no two arms touched
};

// Runs the demo of the workcell `cell` (read from `file`). Errors that stop it before the
// robots move are returned; a failure after that is said on `warn`, with ok false.
Result<CellDemoResult> run_cell_demo(const Workcell& cell, const std::filesystem::path& file,
                                     const CellDemoOptions& options, const Say& say,
                                     const Say& warn);

}  // namespace scaratwin::session
