// scaratwin model: writes the MuJoCo model (MJCF) and a URDF of the arm generated from the
// robot description, or of a whole workcell of robots (--workcell FILE, docs/workcell.md), for
// viewers and other tools.
#include <cstdio>
#include <fstream>
#include <memory>

#include "commands.hpp"
#include "scaratwin/config/workcell_config.hpp"
#include "scaratwin/sim/mjcf.hpp"

namespace scaratwin::cli {
namespace {

struct ModelArgs {
  std::string mjcf_path;
  std::string urdf_path;
  std::string workcell_path;  // empty: the robot description alone
  int cubes_per_color = 4;
};

bool write_file(const std::string& path, const std::string& text) {
  std::ofstream out(path, std::ios::binary);
  out << text;
  out.close();
  if (!out) {
    std::fprintf(stderr, "scaratwin model: cannot write '%s'\n", path.c_str());
    return false;
  }
  return true;
}

// The whole workcell: its robots' descriptions come from the workcell file, not --config.
int run_workcell(const CommonOptions& common, const ModelArgs& a) {
  if (!common.config_path.empty()) {
    std::fprintf(stderr,
                 "scaratwin model: --config and --workcell: give one (the workcell file names "
                 "each robot's description)\n");
    return kExitUsage;
  }
  auto workcell = load_workcell_config(a.workcell_path);
  if (!workcell) {
    std::fprintf(stderr, "scaratwin model: %s\n", workcell.error().message.c_str());
    return kExitUsage;
  }
  if (!a.mjcf_path.empty()) {
    sim::MjcfOptions o;
    o.cubes_per_color = a.cubes_per_color;
    auto xml = sim::make_mjcf(*workcell, o);
    if (!xml) {
      std::fprintf(stderr, "scaratwin model: %s\n", xml.error().message.c_str());
      return kExitUsage;
    }
    if (!write_file(a.mjcf_path, *xml)) return kExitFailure;
  }
  if (!a.urdf_path.empty()) {
    auto urdf = sim::make_urdf(*workcell);
    if (!urdf) {
      std::fprintf(stderr, "scaratwin model: %s\n", urdf.error().message.c_str());
      return kExitUsage;
    }
    if (!write_file(a.urdf_path, *urdf)) return kExitFailure;
  }
  return kExitOk;
}

int run_model(const CommonOptions& common, const ModelArgs& a) {
  if (a.mjcf_path.empty() && a.urdf_path.empty()) {
    std::fprintf(stderr, "scaratwin model: give --mjcf FILE and/or --urdf FILE\n");
    return kExitUsage;
  }
  if (!a.workcell_path.empty()) return run_workcell(common, a);
  auto model = load_model(common);
  if (!model) return kExitUsage;
  if (!a.mjcf_path.empty()) {
    sim::MjcfOptions o;
    o.cubes_per_color = a.cubes_per_color;
    auto xml = sim::make_mjcf(*model, o);
    if (!xml) {
      std::fprintf(stderr, "scaratwin model: %s\n", xml.error().message.c_str());
      return kExitUsage;
    }
    if (!write_file(a.mjcf_path, *xml)) return kExitFailure;
  }
  if (!a.urdf_path.empty()) {
    auto urdf = sim::make_urdf(*model);
    if (!urdf) {
      std::fprintf(stderr, "scaratwin model: %s\n", urdf.error().message.c_str());
      return kExitUsage;
    }
    if (!write_file(a.urdf_path, *urdf)) return kExitFailure;
  }
  return kExitOk;
}

}  // namespace

void add_model_command(CLI::App& app, CommonOptions& common, Runner& run) {
  auto a = std::make_shared<ModelArgs>();
  CLI::App* cmd = app.add_subcommand(
      "model", "write the MuJoCo model (MJCF) or a URDF of the arm, from the robot description");
  cmd->add_option("--mjcf", a->mjcf_path, "write the MJCF scene (robot, table, trays, camera)");
  cmd->add_option("--urdf", a->urdf_path, "write a URDF of the arm");
  cmd->add_option("--workcell", a->workcell_path,
                  "write the whole workcell of a workcell file (robots at their base poses "
                  "around one scene, names prefixed '<robot>/'; docs/workcell.md) instead of "
                  "one robot description");
  cmd->add_option("--cubes-per-color", a->cubes_per_color, "cube pool size per colour")
      ->capture_default_str();
  add_common_options(*cmd, common, false);
  cmd->callback([&common, &run, a] { run = [&common, a] { return run_model(common, *a); }; });
}

}  // namespace scaratwin::cli
