// scaratwin sim / scaratwin robot: run the executables `scaratwin-sim` and `scaratwin-robot`
// installed beside this one (as git does), passing every argument after the subcommand
// through. The emulator is its own executable because it links GPL-3.0 libsimavr.
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
  std::fprintf(stderr, "scaratwin: cannot run %s: %s\n", argv[0], std::strerror(errno));
  return kExitFailure;
}

}  // namespace

void add_sim_command(CLI::App& app, CommonOptions& /*common*/, Runner& run) {
  struct Layer {
    const char* sub;
    const char* exe;
    const char* help;
  };
  static constexpr Layer kLayers[] = {
      {"sim", "scaratwin-sim",
       "run the virtual robot (MuJoCo simulator, camera, TCP server on 127.0.0.1:55016); "
       "arguments go to scaratwin-sim (try: scaratwin sim --help)"},
      {"robot", "scaratwin-robot",
       "run the emulated physical robot (our firmware in simavr, serial port on a pty); "
       "arguments go to scaratwin-robot (GPL-3.0; try: scaratwin robot --help)"},
  };
  for (const Layer& layer : kLayers) {
    CLI::App* cmd = app.add_subcommand(layer.sub, layer.help);
    cmd->prefix_command();
    cmd->set_help_flag();  // --help goes through to the executable
    cmd->callback([cmd, &run, exe = layer.exe] {
      auto args = std::make_shared<std::vector<std::string>>(cmd->remaining());
      run = [args, exe] { return exec_sibling(exe, *args); };
    });
  }
}

}  // namespace scaratwin::cli
