// The links of the commands that hold a hub (the statements, `run`, `hub`): their options,
// and one hub session from connect to the end of its run, with Ctrl-C handling.
#pragma once

#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "commands.hpp"
#include "scaratwin/hub/hub.hpp"
#include "scaratwin/session/links.hpp"

namespace scaratwin::cli {

// --serial, --sim, --sim-token, --db, --no-db, --workcell, --robot and the report rate.
using LinkArgs = session::LinkOptions;

// Adds --serial, --sim, --sim-token, --db, --no-db, --workcell and --robot.
void add_link_options(CLI::App& cmd, LinkArgs& l);

// Connects a hub to the robot and the simulator, begins a run (`kind`, `label`) in the twin
// database, mirrors, runs `body` and ends the run. Ctrl-C (or SIGTERM) interrupts the hub
// (Hub::interrupt()) and a second one ends the process. Returns the exit status; a failing
// body's error is printed as "scaratwin <kind>: <message>".
int with_hub(const CommonOptions& common, const LinkArgs& l, const std::string& kind,
             const std::string& label, const std::function<Status(Hub&)>& body);

// A hub and the name of the workcell's robot it drives.
struct NamedHub {
  std::string name;
  Hub* hub = nullptr;
};

// As with_hub(), for every robot of the workcell at once when --robot is not given (--robot:
// that one; one robot: as with_hub()): one hub each, on its serial port (--serial NAME=DEVICE),
// recording into its own database (twin-NAME.db beside --db), all mirrored into the one
// simulator. Ctrl-C interrupts every hub. `body` runs once with all of them.
int with_hubs(const CommonOptions& common, const LinkArgs& l, const std::string& kind,
              const std::string& label,
              const std::function<Status(const std::vector<NamedHub>&)>& body);

}  // namespace scaratwin::cli
