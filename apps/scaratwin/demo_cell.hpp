// `scaratwin demo --robots N`: N emulated robots on one table of one simulator, sorting the
// cubes together (docs/workcell.md "Two arms, one table").
#pragma once

#include <filesystem>
#include <string>

#include "commands.hpp"

namespace scaratwin::cli {

struct CellDemoOptions {
  int robots = 2;
  std::string workcell;  // the workcell file; empty: config/two_arms_trays.toml
  std::filesystem::path out;
  int http_port = 8080;
  double robot_speed = 1.0;
  unsigned seed = 7;
  // Each robot is a robot as built (scaratwin-robot --plant as-built): robot i's build is drawn
  // with seed as_built_seed + i (-1: its description's [as_built] seed + i). `ideal`: the
  // exact robots (--plant ideal) instead.
  long long as_built_seed = -1;
  bool ideal = false;
  int cubes = 3;
  bool keep_open = false;
};

// Returns the process's exit code (kExitOk only if every cube ends in its tray, no frame of
// any robot was lost and no two arms touched).
int run_cell_demo(const CellDemoOptions& options);

}  // namespace scaratwin::cli
