#include "scaratwin/session/links.hpp"

#include <cstdlib>
#include <filesystem>
#include <map>

#include <fmt/format.h>

#include "scaratwin/core/error_codes.hpp"
#include "scaratwin/session/address.hpp"

namespace scaratwin::session {
namespace {

namespace fs = std::filesystem;

// The robots the command drives (indices into the cell): the one of --robot, the only one, or
// with `every` all of them.
Result<std::vector<int>> chosen_robots(const Workcell& cell, const LinkOptions& l, bool every) {
  if (!l.robot.empty()) {
    auto k = robot_index(cell, l.robot);
    if (!k) return k.error();
    return std::vector<int>{*k};
  }
  if (cell.robots.size() > 1 && !every) {
    return Error{error_code(ConfigError::kUnknownRobot),
                 fmt::format("{} has {} robots ({}): say which one with --robot NAME", l.workcell,
                             cell.robots.size(), robot_names(cell))};
  }
  std::vector<int> all;
  for (std::size_t i = 0; i < cell.robots.size(); ++i) all.push_back(static_cast<int>(i));
  return all;
}

// Each chosen robot's serial port: with one robot, --serial DEVICE (or $SCARATWIN_SERIAL);
// with several, --serial NAME=DEVICE once for each.
Result<std::vector<std::string>> serial_ports(const Workcell& cell, const std::vector<int>& chosen,
                                              const LinkOptions& l, const std::string& kind) {
  const int invalid = error_code(ConfigError::kInvalid);
  if (chosen.size() == 1) {
    const std::string& name = cell.robots[static_cast<std::size_t>(chosen[0])].name;
    if (l.serial.size() > 1) {
      return Error{invalid, fmt::format("--serial given {} times: this command drives one "
                                        "robot ('{}')",
                                        l.serial.size(), name)};
    }
    std::string device = l.serial.empty() ? std::string() : l.serial[0];
    // NAME=DEVICE naming this very robot is accepted too
    if (device.rfind(name + "=", 0) == 0) device = device.substr(name.size() + 1);
    if (device.empty()) {
      if (const char* env = std::getenv("SCARATWIN_SERIAL")) device = env;
    }
    if (device.empty()) {
      return Error{invalid,
                   "no robot: pass --serial DEVICE or set SCARATWIN_SERIAL (start one with "
                   "`scaratwin robot`)"};
    }
    return std::vector<std::string>{device};
  }
  std::map<int, std::string> by_robot;
  std::map<std::string, int> by_device;
  for (const std::string& given : l.serial) {
    const size_t eq = given.find('=');
    if (eq == std::string::npos || eq == 0 || eq + 1 == given.size()) {
      return Error{invalid,
                   fmt::format("--serial '{}': this {} drives {} robots ({}); give each one's "
                               "port as --serial NAME=DEVICE",
                               given, kind, chosen.size(), robot_names(cell))};
    }
    auto k = robot_index(cell, given.substr(0, eq));
    if (!k) return Error{invalid, "--serial '" + given + "': " + k.error().message};
    const std::string device = given.substr(eq + 1);
    const std::string& name = cell.robots[static_cast<std::size_t>(*k)].name;
    if (by_robot.count(*k) != 0) {
      return Error{invalid, fmt::format("--serial names robot '{}' twice", name)};
    }
    if (auto other = by_device.find(device); other != by_device.end()) {
      return Error{
          invalid,
          fmt::format("--serial: robots '{}' and '{}' are both on {}; each robot has a "
                      "port of its own",
                      cell.robots[static_cast<std::size_t>(other->second)].name, name, device)};
    }
    by_robot[*k] = device;
    by_device[device] = *k;
  }
  std::vector<std::string> ports;
  for (const int k : chosen) {
    auto it = by_robot.find(k);
    if (it == by_robot.end()) {
      const std::string& name = cell.robots[static_cast<std::size_t>(k)].name;
      return Error{invalid, fmt::format("no serial port for robot '{}': pass --serial "
                                        "{}=DEVICE (one for each of {})",
                                        name, name, robot_names(cell))};
    }
    ports.push_back(it->second);
  }
  return ports;
}

}  // namespace

Result<std::vector<RobotLink>> robot_links(const Workcell& workcell, const LinkOptions& l,
                                           const std::string& kind, bool every) {
  const Workcell* cell = &workcell;
  auto chosen = chosen_robots(*cell, l, every);
  if (!chosen) return chosen.error();
  auto ports = serial_ports(*cell, *chosen, l, kind);
  if (!ports) return ports.error();
  const auto sim = parse_host_port(l.sim);
  if (!sim) {
    return Error{error_code(ConfigError::kInvalid),
                 fmt::format("--sim '{}': expected HOST:PORT (a port of 1..65535)", l.sim)};
  }
  std::string token = l.sim_token;
  if (token.empty()) {
    if (const char* env = std::getenv("SCARATWIN_TOKEN"); env != nullptr) token = env;
  }
  std::vector<RobotLink> links;
  for (std::size_t n = 0; n < chosen->size(); ++n) {
    const int index = (*chosen)[n];
    const RobotInstance& instance = cell->robots[static_cast<std::size_t>(index)];
    RobotLink link;
    link.name = instance.name;
    // the robot's own view: the scene in its base frame (cube positions are the robot's)
    link.model = scene_in_base(*cell, index);
    HubOptions& o = link.options;
    o.sim_robot = index;
    o.base = instance.base;
    o.report_rate_hz = l.report_hz;
    o.serial_device = (*ports)[n];
    o.sim_host = sim->host;
    o.sim_port = sim->port;
    o.sim_token = token;
    o.description_source = instance.description_file;
    if (chosen->size() > 1) o.log_name = instance.name;  // says which robot a message is of
    // stop acts on the robot alone, so it may run while another hub controls the simulator
    if (kind == "stop") o.sim_role = "observe";
    if (!l.no_db) {
      // several robots: one database each, twin-left.db beside --db's twin.db
      fs::path db = l.db;
      if (chosen->size() > 1) {
        db = db.parent_path() /
             fmt::format("{}-{}{}", db.stem().string(), instance.name, db.extension().string());
      }
      link.db = db.string();
    }
    links.push_back(std::move(link));
  }
  return links;
}

}  // namespace scaratwin::session
