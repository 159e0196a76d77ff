// The simulator of config/two_arms.toml (no camera) serving on an ephemeral loopback port, for
// the tests of a workcell's server.
#pragma once

#include <filesystem>
#include <memory>

#include <gtest/gtest.h>

#include "scaratwin/config/workcell_config.hpp"
#include "scaratwin/sim/server.hpp"
#include "scaratwin/sim/world.hpp"

namespace scaratwin::sim::test {

struct TwoArmsServer {
  std::unique_ptr<World> world;
  std::unique_ptr<SimServer> server;
};

// Fills `out`; a failure is the calling test's (ASSERT_NO_FATAL_FAILURE around the call).
// `speed` as scaratwin-sim's --speed (0: max).
inline void start_two_arms_server(TwoArmsServer* out, double speed = 1.0) {
  auto cell = load_workcell_config(std::filesystem::path(SCARATWIN_CONFIG_FILE).parent_path() /
                                   "two_arms.toml");
  ASSERT_TRUE(cell.ok()) << cell.error().message;
  WorldOptions wo;
  wo.camera = false;
  wo.speed = speed;
  auto w = World::create(*cell, {}, wo);
  ASSERT_TRUE(w.ok()) << w.error().message;
  ServerOptions o;
  o.port = 0;
  auto s = SimServer::create(**w, o);
  ASSERT_TRUE(s.ok()) << s.error().message;
  out->world = std::move(*w);
  out->server = std::move(*s);
}

}  // namespace scaratwin::sim::test
