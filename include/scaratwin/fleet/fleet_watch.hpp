// A dashboard's view of the fleet: subscribes to every robot's state and connection topics on
// a broker (docs/fleet.md) and keeps the last word of each robot, for the browser UI's fleet
// page (served by the simulator's web server at /fleet.html, its data at /api/fleet). Nothing
// here commands a robot. The broker may be down: the watcher retries on its own thread with
// back-off and says so once; the snapshot then reads "connected": false.
#pragma once

#include <chrono>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <string_view>

#include "scaratwin/core/result.hpp"
#include "scaratwin/fleet/topics.hpp"

struct mosquitto;
struct mosquitto_message;

namespace scaratwin::fleet {

// At most this many robots are kept (the rest are counted as ignored), and a state payload
// larger than this is not parsed: a stranger on the broker cannot grow the watcher without
// bound.
inline constexpr std::size_t kMaxWatchedRobots = 1000;
inline constexpr std::size_t kMaxStateBytes = 16384;

struct WatchCounters {
  std::uint64_t states = 0;     // state messages kept
  std::uint64_t malformed = 0;  // state payloads that are not a JSON object, or too large
  std::uint64_t ignored = 0;    // messages on topics outside the layout, or beyond the robot cap
  std::uint64_t connects = 0;   // CONNACKs accepted
};

// What is known of one robot. `state_json` is the last state payload as received ("" before
// the first), `connection` the retained connection word ("" when none was seen).
struct RobotView {
  std::string connection;
  std::string state_json;
  std::chrono::steady_clock::time_point last_state{};
  std::uint64_t states = 0;
};

class FleetWatcher {
 public:
  using Log = std::function<void(const std::string&)>;
  // Starts watching; fails only on a bad address or a library error, never because the broker
  // is down (then it retries in the background).
  static Result<std::unique_ptr<FleetWatcher>> start(const BrokerAddress& broker, Log log);
  ~FleetWatcher();
  FleetWatcher(const FleetWatcher&) = delete;
  FleetWatcher& operator=(const FleetWatcher&) = delete;

  bool connected() const;
  WatchCounters counters() const;
  std::map<std::string, RobotView> robots() const;

  // The fleet as JSON for the page:
  // {"broker": "mqtt://host:port", "connected": true,
  //  "robots": [{"name": "r1", "connection": "online", "age_ms": 12.5, "states": 90,
  //              "state": {...the robot's last state payload...}}, ...]}   (sorted by name;
  // "connection" and "state" null when not seen, "age_ms" since the last state, or null)
  std::string snapshot_json() const;

  // Handles one message as it arrived on `topic` (public for the unit tests: the topic and
  // payload rules need no broker).
  void on_message(std::string_view topic, std::string_view payload);

 private:
  FleetWatcher(const BrokerAddress& broker, Log log);
  void on_connect(int rc);
  void on_disconnect(int rc);

  BrokerAddress broker_;
  Log log_;
  mosquitto* mosq_ = nullptr;
  mutable std::mutex mu_;
  std::map<std::string, RobotView> robots_;
  WatchCounters counters_;
  bool connected_ = false;
  std::string last_problem_;
};

}  // namespace scaratwin::fleet
