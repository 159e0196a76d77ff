// The browser UI's server: HTTP for the page's static files (built by npm into the build
// tree, so the page needs no internet) and a WebSocket at /ws carrying the JSON feed of
// feed.hpp to every connected browser, for a running sim::World. One io thread serves all
// connections; a second thread runs the slow commands (camera shots) so the feed never stalls.
//
// Binds 127.0.0.1 unless told otherwise. Several browsers may connect at once; each gets the
// "scene" message on connect and then the "state" stream. A browser that cannot keep up skips
// frames instead of queueing them.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <string>

#include "scaratwin/core/result.hpp"
#include "scaratwin/sim/world.hpp"
#include "scaratwin/web/link_monitor.hpp"

namespace scaratwin::web {

inline constexpr std::uint16_t kDefaultHttpPort = 8080;

// Where the built page is: the build tree's web/www, or the installed data folder's web/
// (scaratwin/config/data_paths.hpp).
std::string default_web_root();

struct WebOptions {
  std::string bind_address = "127.0.0.1";     // "0.0.0.0" to serve other machines
  std::uint16_t port = kDefaultHttpPort;      // 0: an ephemeral port (see WebServer::port())
  std::string root_dir = default_web_root();  // folder holding index.html and its assets
  double feed_hz = 30.0;                      // state messages per second, 1..120
  int path_every = 5;                         // tool path in every n-th state message
  // Access (docs/security.md): with a token, /ws and /api/ need ?token=<token>. A WebSocket
  // upgrade whose Origin is not the page's own (scheme://Host) is refused with 403, and so is
  // one naming a Host that is not this machine while no token is set (DNS rebinding).
  std::string token;
  // Replies (pictures, ...) a browser leaves unread beyond this are not queued: it is cut.
  std::size_t max_unread_bytes = std::size_t{16} << 20;
  // The fleet page's data (/api/fleet: JSON, e.g. fleet::FleetWatcher::snapshot_json); empty:
  // this server watches no fleet and /api/fleet answers 404 saying so.
  std::function<std::string()> fleet;
  // A workcell's: each robot's link figures, robot 0 first (empty: only the link panel's).
  std::function<std::vector<LinkStatus>()> robot_links;
};

// Link figures for the feed; returns an empty status when the simulator has no link data.
using LinkStatusFn = std::function<LinkStatus()>;

class WebServer {
 public:
  // Binds and listens before returning (errors name the address and the port, or the missing
  // index.html), then serves on its own threads until destroyed. `link` may be empty.
  static Result<std::unique_ptr<WebServer>> create(sim::World& world, const WebOptions& options,
                                                   LinkStatusFn link = {});
  ~WebServer();
  WebServer(const WebServer&) = delete;
  WebServer& operator=(const WebServer&) = delete;

  std::uint16_t port() const;
  std::size_t clients() const;     // WebSocket connections open now
  std::uint64_t commands() const;  // commands received from pages

 private:
  WebServer();
  struct Impl;
  std::shared_ptr<Impl> impl_;
};

}  // namespace scaratwin::web
