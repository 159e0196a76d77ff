// scaratwin sim: runs the simulator executable `scaratwin-sim` installed beside this one,
// passing every argument after `sim` through (see `scaratwin sim --help`).
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <memory>
#include <vector>

#include "commands.hpp"

namespace scaratwin::cli {
namespace {

int exec_sibling(const char* name, const std::vector<std::string>& args) {
  std::error_code ec;
  const auto self = std::filesystem::read_symlink("/proc/self/exe", ec);
  const auto exe = ec ? std::filesystem::path(name) : self.parent_path() / name;
  std::vector<std::string> argv_s{exe.string()};
  argv_s.insert(argv_s.end(), args.begin(), args.end());
  std::vector<char*> argv;
  for (std::string& s : argv_s) argv.push_back(s.data());
  argv.push_back(nullptr);
  ::execv(argv[0], argv.data());
  std::fprintf(stderr, "scaratwin sim: cannot run %s: %s\n", argv[0], std::strerror(errno));
  return kExitFailure;
}

}  // namespace

void add_sim_command(CLI::App& app, CommonOptions& /*common*/, Runner& run) {
  CLI::App* cmd = app.add_subcommand(
      "sim",
      "run the virtual robot (MuJoCo simulator, camera, TCP server on 127.0.0.1:55016); "
      "arguments go to scaratwin-sim (try: scaratwin sim --help)");
  cmd->prefix_command();
  cmd->set_help_flag();  // --help goes through to scaratwin-sim
  cmd->callback([cmd, &run] {
    auto args = std::make_shared<std::vector<std::string>>(cmd->remaining());
    run = [args] { return exec_sibling("scaratwin-sim", *args); };
  });
}

}  // namespace scaratwin::cli
