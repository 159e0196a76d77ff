// The JSON feed of the browser UI and the commands it sends back, independent of any network
// code (the WebSocket server in web_server.hpp carries these strings).
//
// Server -> page (one JSON object per WebSocket text message, field "type"):
//   "scene"  once per connection: robot description (joint names, limits, home), the MuJoCo
//            model's bodies and geoms (type, size, pose in the body, colour), the trays, the
//            overhead camera (pose, axes, field of view, image size) and the feed rate;
//   "state"  at the feed rate: sim time and mode, joints (measured and commanded), tool pose,
//            gripper, every body's pose, cubes, joint-limit flags and warnings, link figures
//            (connected, frames, lost, latency, the physical joints) and, every few frames,
//            the tool's recent path;
//   "reply"  to a command: {"id", "ok", "error"?, ...};
//   "image"  a camera picture: {"id", "width", "height", "png_base64"}.
// Page -> server: {"cmd": "spawn", "color": "red"|"green"|"blue", "x_mm"?, "y_mm"?, "id"?},
//   {"cmd": "reset"}, {"cmd": "shoot"}, {"cmd": "ping"}.
//
// Units on the wire of the feed: metres and radians for poses (three.js works in the model's
// frame B, z up), joints as SI plus display values (d1 in mm, angles in degrees) so the page
// converts nothing; times in seconds.
#pragma once

#include <cstdint>
#include <optional>
#include <random>
#include <string>
#include <string_view>

#include "scaratwin/core/result.hpp"
#include "scaratwin/sim/spawn.hpp"
#include "scaratwin/sim/world.hpp"
#include "scaratwin/web/link_monitor.hpp"

namespace scaratwin::web {

// Error codes of the web module: WebError (scaratwin/core/error_codes.hpp, 70..79).

// The "scene" message.
// `fleet`: this server also serves the fleet page (/fleet.html, /api/fleet).
std::string scene_message(const RobotModel& robot, const sim::SceneGeometry& geometry,
                          double feed_hz, bool fleet = false);

struct StateExtras {
  bool with_path = false;    // include the tool path (sent every few frames)
  std::size_t clients = 0;   // browsers connected
  double world_speed = 1.0;  // WorldOptions::speed (0: prediction runs)
  // a workcell's: each robot's link (index = robot; missing: not shown)
  std::vector<LinkStatus> robot_links;
};
// The "state" message.
std::string state_message(const RobotModel& robot, const sim::Snapshot& snapshot,
                          const LinkStatus& link, const StateExtras& extras);

// The mode the UI shows: the hub's word if it gave one, else mirror (sim in mirror mode),
// prediction (simulate mode, running as fast as possible) or control (simulate, real time).
std::string twin_mode(const sim::Snapshot& snapshot, const LinkStatus& link, double world_speed);

struct Command {
  enum class Kind { kSpawn, kReset, kShoot, kPing };
  Kind kind = Kind::kPing;
  std::optional<std::int64_t> id;  // echoed in the reply
  CubeColor color = CubeColor::kRed;
  std::optional<double> x_m, y_m;  // spawn position; both absent: a free random spot
};
Result<Command> parse_command(std::string_view text);

// Runs spawn, reset or ping on the world and returns the "reply" message. (A shot is slow and
// is run by the server off its network thread: see shoot_message.)
std::string execute_command(sim::World& world, const Command& command, std::mt19937_64& rng);

// The page's spawn button without a position: a free random spot (scaratwin/sim/spawn.hpp).
using sim::spawn_at_random;

// The "image" message for a PNG (or a failed "reply" if the shot failed).
std::string shoot_message(sim::World& world, const Command& command);

// A "reply" with ok = false.
std::string error_reply(std::optional<std::int64_t> id, const std::string& message);

}  // namespace scaratwin::web
