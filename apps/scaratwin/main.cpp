// scaratwin: the one command line of the digital twin. Subcommands are registered from
// cmd_*.cpp; long-running layers (simulator, emulator) may run as separate executables
// installed beside this one.
#include <cstdio>

#include "commands.hpp"

int main(int argc, char** argv) {
  using namespace scaratwin::cli;
  CLI::App app{
      "scaratwin: digital twin of a low-cost desktop SCARA robot (kinematics, planning, "
      "simulation, physical robot, mirror and reports)",
      "scaratwin"};
  app.require_subcommand(1);
  app.set_version_flag("--version", "scaratwin 0.1.0");
  CommonOptions common;
  Runner run;
  add_kinematics_commands(app, common, run);
  add_plan_command(app, common, run);
  add_model_command(app, common, run);
  add_sim_command(app, common, run);
  add_report_commands(app, common, run);
  add_demo_command(app, common, run);
  add_statement_commands(app, common, run);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? kExitOk : kExitUsage;
  }
  return run ? run() : kExitUsage;
}
