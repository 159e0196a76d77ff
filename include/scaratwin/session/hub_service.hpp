// A long-running hub's service (`scaratwin hub`): the statements that arrive from the fleet's
// command topic (docs/fleet.md) and from the local clients of the robot's port owner
// (port_owner.hpp: each statement and `scaratwin run` of this machine), in one queue, run one at
// a time on the hub with the command line's checks; `stop` goes before everything that waits.
#pragma once

#include <optional>
#include <string>

#include "scaratwin/core/result.hpp"
#include "scaratwin/fleet/topics.hpp"
#include "scaratwin/hub/hub.hpp"
#include "scaratwin/session/port_owner.hpp"
#include "scaratwin/session/say.hpp"

namespace scaratwin::session {

struct HubServiceOptions {
  std::string name;                            // the robot's name in the fleet's topics
  std::optional<fleet::BrokerAddress> broker;  // join the fleet on this broker
  double state_hz = 10.0;                      // state messages per second on the fleet
  int queue = 8;                               // commands that may wait behind the running one
  std::string log_prefix;  // before each command's line: the robot's name when there are several
};

// Serves until the hub is interrupted (Ctrl-C: HubError::kInterrupted) or the fleet's bridge
// cannot start; with `owner`, its local clients too. Each command's line goes to `say`.
Status serve_hub(Hub& hub, const HubServiceOptions& options, PortOwner* owner, const Say& say);

}  // namespace scaratwin::session
