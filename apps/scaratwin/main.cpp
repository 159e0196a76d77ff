// scaratwin: the one command line of the digital twin. Subcommands are registered from
// cmd_*.cpp; long-running layers (simulator, emulator) may run as separate executables
// installed beside this one.
#include <cstdio>
#include <string>

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
  add_calibrate_command(app, common, run);
  add_statement_commands(app, common, run);
  add_hub_command(app, common, run);
  add_flash_command(app, common, run);
  add_bench_command(app, common, run);
  // the first word that is not an option must name a subcommand: say which word is unknown
  // (CLI11 would answer "A subcommand is required", or show the help and exit 0 with --help)
  if (argc > 1 && argv[1][0] != '-') {
    const std::string word = argv[1];
    std::string known;
    bool found = false;
    for (const CLI::App* sub : app.get_subcommands([](CLI::App*) { return true; })) {
      found = found || sub->check_name(word);
      known += (known.empty() ? "" : ", ") + sub->get_name();
    }
    if (!found) {
      std::fprintf(stderr, "scaratwin: unknown command '%s' (commands: %s; see --help)\n",
                   word.c_str(), known.c_str());
      return kExitUsage;
    }
  }
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? kExitOk : kExitUsage;
  }
  return run ? run() : kExitUsage;
}
