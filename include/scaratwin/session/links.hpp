// The links of a twin session that holds a hub for each of the robots it drives (the
// statements, `run`, `hub`): which robots of the workcell, each one's serial port, simulator
// address and database, as HubOptions ready to connect.
#pragma once

#include <string>
#include <vector>

#include "scaratwin/core/result.hpp"
#include "scaratwin/hub/hub.hpp"
#include "scaratwin/kinematics/workcell.hpp"

namespace scaratwin::session {

struct LinkOptions {
  std::vector<std::string> serial;  // DEVICE, or NAME=DEVICE per robot for several
  std::string sim = "127.0.0.1:55016";
  std::string sim_token;  // empty: $SCARATWIN_TOKEN
  std::string db = "scaratwin-out/twin.db";
  bool no_db = false;
  std::string workcell;  // the workcell file (said in messages; the cell itself is given)
  std::string robot;     // which of the workcell's robots (empty: the only one)
  int report_hz = 100;   // the robot's state reports while the hub holds it
};

// One robot's session as the command opens it.
struct RobotLink {
  std::string name;
  RobotModel model;  // its description, the scene in its base frame
  HubOptions options;
  std::string db;  // empty: record nothing
};

// The robots a command of `kind` drives in `cell`, each with its link: the one of `robot`, the
// only one, or with `every` all of them. With one robot its port is `serial` (DEVICE, or its
// NAME=DEVICE; empty: $SCARATWIN_SERIAL); with several, NAME=DEVICE once for each, every robot
// on a port of its own. Several robots record into one database each, twin-NAME.db beside
// `db`. Errors name the option that is wrong.
Result<std::vector<RobotLink>> robot_links(const Workcell& cell, const LinkOptions& options,
                                           const std::string& kind, bool every);

}  // namespace scaratwin::session
