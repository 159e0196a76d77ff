// Who may use the simulator's TCP port, judged on a connection's first line (docs/security.md):
// a first line that is an HTTP request is no hub, and the controlling clients are counted per
// robot. Pure: no sockets, no simulation (the server applies the verdicts).
#pragma once

#include <mutex>
#include <optional>
#include <string_view>
#include <vector>

namespace scaratwin::sim {

// Whether a connection's first line starts like an HTTP request (a web page reaching the
// port, docs/security.md): a method and a space.
bool looks_like_http(std::string_view first_line);

// One controller per robot (docs/workcell.md): the link's controlling client drives the robot
// its hello named, or every robot (a hello naming none); each further controller names another
// robot that nobody drives yet and is served apart. Thread-safe: the server's io thread claims
// and releases, any thread asks.
class ControllerClaims {
 public:
  explicit ControllerClaims(int robots);

  enum class Verdict {
    kControl,  // the link's controlling client
    kServe,    // a controller of the robot it named, served apart beside the link's
    kInUse,    // refused: what it names is driven already
  };
  // A new controlling client whose hello names `robot` (nullopt: every robot; an index the
  // simulator has); `link_held`: the link has its controlling client already.
  Verdict claim(std::optional<int> robot, bool link_held);
  // A controller served apart went away: its robot is free again.
  void release(int robot);
  // The robot the link's controlling client drives (nullopt: every robot).
  std::optional<int> session_robot() const;
  // Whether a client drives `robot`; `link_connected`: the link's controlling client is there.
  bool controlled(int robot, bool link_connected) const;

 private:
  mutable std::mutex mutex_;
  std::optional<int> session_robot_;
  std::vector<char> served_;  // per robot: a controller served apart drives it
};

}  // namespace scaratwin::sim
