#include "scaratwin/fleet/mqtt_bridge.hpp"

#include <mosquitto.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstring>

#include <fmt/format.h>

#include "mqtt_client.hpp"

namespace scaratwin::fleet {
namespace {

constexpr std::string_view kOnline = "online";
constexpr std::string_view kOffline = "offline";
constexpr int kQosCommand = 1;

MqttBridge* self(void* user) { return static_cast<MqttBridge*>(user); }

}  // namespace

Result<std::unique_ptr<MqttBridge>> MqttBridge::start(const BridgeOptions& options,
                                                      CommandHandler on_command, Log log) {
  if (Status s = check_robot_name(options.robot); !s) return s.error();
  if (options.keepalive_s < 5) {
    return Error{kBadUrl, fmt::format("MQTT keep-alive {} s: at least 5 s", options.keepalive_s)};
  }
  if (Status s = init_mqtt_library(); !s) return s.error();
  // the password and the TLS files are read now: a bad one is said at start, not retried
  auto broker = detail::load_credentials(options.broker);
  if (!broker) return broker.error();
  BridgeOptions resolved = options;
  resolved.broker = std::move(*broker);
  std::unique_ptr<MqttBridge> b(new MqttBridge(resolved, std::move(on_command), std::move(log)));
  const std::string id = options.client_id.empty()
                             ? fmt::format("scaratwin-{}-{}", options.robot, getpid())
                             : options.client_id;
  b->mosq_ = mosquitto_new(id.c_str(), true, b.get());
  if (b->mosq_ == nullptr) return Error{kBadUrl, "libmosquitto: cannot create a client"};
  mosquitto_int_option(b->mosq_, MOSQ_OPT_PROTOCOL_VERSION, MQTT_PROTOCOL_V311);
  // a state message is small and must leave now: without this, Nagle's algorithm holds it
  // behind the previous one until that one's (delayed) ACK, about 40 ms on Linux loopback
  mosquitto_int_option(b->mosq_, MOSQ_OPT_TCP_NODELAY, 1);
  mosquitto_threaded_set(b->mosq_, true);
  if (Status s = detail::configure_client(b->mosq_, b->options_.broker); !s) return s.error();
  // a hub that dies (killed, its machine gone) reads offline: the broker publishes the will
  const int rc =
      mosquitto_will_set(b->mosq_, b->topics_.connection.c_str(), static_cast<int>(kOffline.size()),
                         kOffline.data(), kQosCommand, true);
  if (rc != MOSQ_ERR_SUCCESS) {
    return Error{kBadUrl, fmt::format("MQTT last will: {}", mosquitto_strerror(rc))};
  }
  mosquitto_connect_callback_set(b->mosq_,
                                 [](mosquitto*, void* u, int r) { self(u)->on_connect(r); });
  mosquitto_disconnect_callback_set(b->mosq_,
                                    [](mosquitto*, void* u, int r) { self(u)->on_disconnect(r); });
  mosquitto_message_callback_set(
      b->mosq_, [](mosquitto*, void* u, const mosquitto_message* m) { self(u)->on_message(*m); });
  b->thread_ = std::thread([p = b.get()] { p->run(); });
  return b;
}

MqttBridge::MqttBridge(const BridgeOptions& options, CommandHandler on_command, Log log)
    : options_(options),
      topics_(robot_topics(options.robot)),
      on_command_(std::move(on_command)),
      log_(std::move(log)) {}

MqttBridge::~MqttBridge() {
  {
    std::lock_guard<std::mutex> lock(mu_);
    stop_ = true;
  }
  cv_.notify_all();
  if (thread_.joinable()) thread_.join();
  if (mosq_ != nullptr) mosquitto_destroy(mosq_);
}

BridgeCounters MqttBridge::counters() const {
  std::lock_guard<std::mutex> lock(mu_);
  return counters_;
}

void MqttBridge::say(const std::string& line) {
  if (log_) log_(line);
}

bool MqttBridge::pause(double s) {
  std::unique_lock<std::mutex> lock(mu_);
  cv_.wait_for(lock, std::chrono::duration<double>(s), [this] { return stop_.load(); });
  return !stop_;
}

void MqttBridge::run() {
  const std::string where = broker_label(options_.broker);
  double backoff_s = options_.retry_min_s;
  bool first = true;
  bool socket_open = false;
  const auto failed = [&](const std::string& why) {
    connected_ = false;
    socket_open = false;
    bool news = false;
    {
      std::lock_guard<std::mutex> lock(mu_);
      ++counters_.failed_attempts;
      news = why != last_problem_;
      last_problem_ = why;
    }
    // said once per problem, not once per attempt
    if (news) {
      say(fmt::format("broker {}: {}; the twin runs on, retrying (back-off up to {:.0f} s)", where,
                      why, options_.retry_max_s));
    }
    (void)pause(backoff_s);
    backoff_s = std::min(backoff_s * 2.0, options_.retry_max_s);
  };
  while (!stop_) {
    if (!socket_open) {
      const int rc = first ? mosquitto_connect(mosq_, options_.broker.host.c_str(),
                                               options_.broker.port, options_.keepalive_s)
                           : mosquitto_reconnect(mosq_);
      if (rc != MOSQ_ERR_SUCCESS) {
        failed(detail::explain_failure(rc, errno, options_.broker, false));
        continue;
      }
      first = false;
      socket_open = true;
      answered_ = false;
    }
    const int rc = mosquitto_loop(mosq_, 100, 1);
    if (rc != MOSQ_ERR_SUCCESS) {
      failed(detail::explain_failure(rc, errno, options_.broker, answered_.load()));
      continue;
    }
    if (connected_) backoff_s = options_.retry_min_s;
  }
  if (!socket_open) return;
  // a clean goodbye: "offline" first (a clean disconnect does not fire the will), then the
  // DISCONNECT, each given a moment to leave
  if (connected_) {
    (void)mosquitto_publish(mosq_, nullptr, topics_.connection.c_str(),
                            static_cast<int>(kOffline.size()), kOffline.data(), kQosCommand, true);
    for (int i = 0; i < 5; ++i) (void)mosquitto_loop(mosq_, 20, 1);
  }
  (void)mosquitto_disconnect(mosq_);
  for (int i = 0; i < 3; ++i) {
    if (mosquitto_loop(mosq_, 20, 1) != MOSQ_ERR_SUCCESS) break;
  }
  connected_ = false;
}

void MqttBridge::on_connect(int rc) {
  answered_ = true;
  if (rc != 0) {
    // refused (bad credentials, protocol, server unavailable): the broker closes the socket
    // and the loop retries with back-off
    std::lock_guard<std::mutex> lock(mu_);
    const std::string why = fmt::format("refused the connection: {}", mosquitto_connack_string(rc));
    if (why != last_problem_ && log_) {
      log_(fmt::format("broker {} {}", broker_label(options_.broker), why));
    }
    last_problem_ = why;
    return;
  }
  (void)mosquitto_subscribe(mosq_, nullptr, topics_.command.c_str(), kQosCommand);
  (void)mosquitto_publish(mosq_, nullptr, topics_.connection.c_str(),
                          static_cast<int>(kOnline.size()), kOnline.data(), kQosCommand, true);
  {
    std::lock_guard<std::mutex> lock(mu_);
    ++counters_.connects;
    last_problem_.clear();
  }
  connected_ = true;
  say(fmt::format("broker {}: connected{}; robot '{}' on {}/{}/", broker_label(options_.broker),
                  options_.broker.tls ? " over TLS" : "", options_.robot, kTopicPrefix,
                  options_.robot));
}

void MqttBridge::on_disconnect(int /*rc*/) { connected_ = false; }

void MqttBridge::on_message(const mosquitto_message& msg) {
  // only this robot's command topic is subscribed; anything else the broker delivers (a
  // session shared by mistake) is never acted on
  if (msg.topic == nullptr || topics_.command != msg.topic) return;
  const std::string_view payload(static_cast<const char*>(msg.payload),
                                 static_cast<std::size_t>(std::max(msg.payloadlen, 0)));
  std::string id_json;
  auto cmd = parse_command(payload, options_.robot, &id_json);
  Error refusal;
  if (!cmd) {
    refusal = cmd.error();
  } else if (msg.retain) {
    // a retained command would run again at every hub start
    refusal = Error{kMalformed, "retained command refused: publish commands without retain"};
  } else if (!options_.accept_commands) {
    refusal = Error{kNoCommands,
                    fmt::format("robot '{}' runs the demo: it takes no commands", options_.robot)};
  } else {
    {
      std::lock_guard<std::mutex> lock(mu_);
      ++counters_.commands;
    }
    if (!on_command_) return;
    Status accepted = on_command_(*cmd);
    if (accepted) return;
    refusal = accepted.error();
  }
  {
    std::lock_guard<std::mutex> lock(mu_);
    ++counters_.refused;
  }
  reply(reply_error(id_json, refusal));
}

void MqttBridge::publish_state(const std::string& json) {
  const bool up = connected_ && mosquitto_publish(mosq_, nullptr, topics_.state.c_str(),
                                                  static_cast<int>(json.size()), json.data(), 0,
                                                  false) == MOSQ_ERR_SUCCESS;
  std::lock_guard<std::mutex> lock(mu_);
  ++(up ? counters_.states_published : counters_.states_dropped);
}

void MqttBridge::reply(const std::string& json) {
  (void)mosquitto_publish(mosq_, nullptr, topics_.reply.c_str(), static_cast<int>(json.size()),
                          json.data(), kQosCommand, false);
}

}  // namespace scaratwin::fleet
