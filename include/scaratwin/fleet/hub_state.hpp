// What a hub publishes about its robot on the fleet's state topic, and how it runs the
// statements that arrive on its command topic: the CLI's statements with the CLI's checks
// (hub/script.hpp, hub/runner.hpp), so a command refused at the command line is refused
// over MQTT with the same message.
#pragma once

#include <atomic>
#include <cstdint>
#include <functional>
#include <string>
#include <string_view>
#include <thread>

#include "scaratwin/core/result.hpp"
#include "scaratwin/fleet/mqtt_bridge.hpp"
#include "scaratwin/hub/hub.hpp"

namespace scaratwin::fleet {

// The command a hub is running or ran last (the state's "job").
struct JobStatus {
  std::string id_json = "null";  // the command's id as sent
  std::string statement;
  bool running = false;
  std::uint64_t done = 0;    // commands that succeeded since the hub started
  std::uint64_t failed = 0;  // commands that failed or were refused
  std::size_t queued = 0;    // commands waiting behind it
  double elapsed_s = 0.0;    // how long the current (or last) command ran
};

// The robot's mode from its last report: "no-report", "halted", "hold", "trajectory",
// "moving", "not-homed" or "idle".
std::string robot_mode(const PhysicalState& ps);

// The state payload (docs/fleet.md): joints, tool, gripper, mode, links, mirror latency and
// loss, alarms and the job. `seq` counts the hub's state messages; "t_ms" is the wall clock
// (milliseconds since the Unix epoch) when it was made.
std::string hub_state_json(const Hub& hub, std::string_view robot, std::uint64_t seq,
                           const JobStatus& job);

// Runs one statement as `scaratwin <statement>` would (parse, then execute on the hub).
// Success: the line the CLI prints. Failure: the message the CLI prints after
// "scaratwin <word>: ". `shoot FILE` is refused (a remote command writes no file on the hub's
// machine).
Result<std::string> run_statement_text(Hub& hub, std::string_view text);

// Publishes the hub's state on the bridge at `rate_hz` from its own thread until destroyed
// (states made while no broker is connected are counted as dropped, not queued).
class StatePublisher {
 public:
  StatePublisher(MqttBridge& bridge, const Hub& hub, std::string robot, double rate_hz,
                 std::function<JobStatus()> job);
  ~StatePublisher();
  StatePublisher(const StatePublisher&) = delete;
  StatePublisher& operator=(const StatePublisher&) = delete;

 private:
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

}  // namespace scaratwin::fleet
