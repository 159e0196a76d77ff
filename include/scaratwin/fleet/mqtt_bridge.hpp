// One robot's bridge to an MQTT broker (libmosquitto, MQTT 3.1.1): announces the robot on its
// retained connection topic (with a last will, so a hub that dies reads "offline"), publishes
// its state, and hands the commands that arrive on its own command topic, checked, to the
// hub. The broker may be down or refuse the connection: the bridge says so once, retries with
// exponential back-off on its own thread, and the local twin never waits for it.
//
// Topic layout and payloads: fleet/topics.hpp, docs/fleet.md.
#pragma once

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <thread>

#include "scaratwin/core/result.hpp"
#include "scaratwin/fleet/topics.hpp"

struct mosquitto;
struct mosquitto_message;

namespace scaratwin::fleet {

// libmosquitto's setup, once per process however often it is called (a second
// mosquitto_lib_init() leaks its TLS password prompt); every broker client of this process,
// ours and the tests' and benchmarks', goes through it. Fails with the library's words.
Status init_mqtt_library();

struct BridgeOptions {
  BrokerAddress broker;
  std::string robot;      // the topic level of this robot (check_robot_name)
  std::string client_id;  // empty: scaratwin-<robot>-<pid>
  int keepalive_s = 5;    // the broker declares the hub dead 1.5 keep-alives after its last word
  double retry_min_s = 0.25;  // back-off after a failed connection: doubles up to retry_max_s
  double retry_max_s = 5.0;
  // false: commands are answered with an error ("takes no commands", e.g. the demo)
  bool accept_commands = true;
};

struct BridgeCounters {
  std::uint64_t connects = 0;          // CONNACKs accepted
  std::uint64_t failed_attempts = 0;   // connections refused, unreachable or lost
  std::uint64_t states_published = 0;  // state messages handed to the broker
  std::uint64_t states_dropped = 0;    // state messages not sent: no broker at the time
  std::uint64_t commands = 0;          // well-formed commands handed to the handler
  std::uint64_t refused = 0;           // payloads refused before the handler (malformed, ...)
};

class MqttBridge {
 public:
  // Called on the bridge's thread for each well-formed command; it must not block for long
  // (queue the work) and answers later with reply(). An error it returns (busy, ...) is
  // replied at once.
  using CommandHandler = std::function<Status(const Command&)>;
  // Lines for the user (connected, broker down, retrying, ...).
  using Log = std::function<void(const std::string&)>;

  // Starts the bridge; fails only on bad options (robot name, library setup), never because
  // the broker is down (it is then retried in the background).
  static Result<std::unique_ptr<MqttBridge>> start(const BridgeOptions& options,
                                                   CommandHandler on_command, Log log);
  // Publishes "offline" (retained), disconnects cleanly and stops the thread.
  ~MqttBridge();
  MqttBridge(const MqttBridge&) = delete;
  MqttBridge& operator=(const MqttBridge&) = delete;

  const RobotTopics& topics() const { return topics_; }
  bool connected() const { return connected_.load(); }
  BridgeCounters counters() const;

  // Publishes a state payload (QoS 0, not retained); dropped while no broker is connected.
  void publish_state(const std::string& json);
  // Publishes a reply payload (QoS 1).
  void reply(const std::string& json);

 private:
  MqttBridge(const BridgeOptions& options, CommandHandler on_command, Log log);
  void run();
  void on_connect(int rc);
  void on_disconnect(int rc);
  void on_message(const mosquitto_message& msg);
  void say(const std::string& line);
  // Sleeps `s` seconds or until the bridge stops; false when it stops.
  bool pause(double s);

  BridgeOptions options_;
  RobotTopics topics_;
  CommandHandler on_command_;
  Log log_;
  mosquitto* mosq_ = nullptr;
  std::atomic<bool> connected_{false};
  std::atomic<bool> answered_{false};  // a CONNACK came on the current connection
  std::atomic<bool> stop_{false};
  mutable std::mutex mu_;  // counters_, and the waits of pause()
  std::condition_variable cv_;
  BridgeCounters counters_;
  std::string last_problem_;  // said once until the next connection (mu_)
  std::thread thread_;
};

}  // namespace scaratwin::fleet
