#include "scaratwin/fleet/fleet_watch.hpp"

#include <mosquitto.h>

#include <algorithm>
#include <cerrno>
#include <cstring>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "mqtt_client.hpp"
#include "scaratwin/fleet/mqtt_bridge.hpp"

namespace scaratwin::fleet {
namespace {

using json = nlohmann::json;

FleetWatcher* self(void* user) { return static_cast<FleetWatcher*>(user); }

constexpr int kKeepaliveS = 10;

}  // namespace

Result<std::unique_ptr<FleetWatcher>> FleetWatcher::start(const BrokerAddress& address, Log log) {
  if (address.host.empty()) return Error{kBadUrl, "MQTT broker: no host"};
  auto loaded = detail::load_credentials(address);
  if (!loaded) return loaded.error();
  const BrokerAddress& broker = *loaded;
  if (Status s = init_mqtt_library(); !s) return s.error();
  std::unique_ptr<FleetWatcher> w(new FleetWatcher(broker, std::move(log)));
  w->mosq_ = mosquitto_new(nullptr, true, w.get());
  if (w->mosq_ == nullptr) return Error{kBadUrl, "libmosquitto: cannot create a client"};
  mosquitto_int_option(w->mosq_, MOSQ_OPT_PROTOCOL_VERSION, MQTT_PROTOCOL_V311);
  mosquitto_int_option(w->mosq_, MOSQ_OPT_TCP_NODELAY, 1);
  if (Status s = detail::configure_client(w->mosq_, broker); !s) return s.error();
  mosquitto_connect_callback_set(w->mosq_,
                                 [](mosquitto*, void* u, int rc) { self(u)->on_connect(rc); });
  mosquitto_disconnect_callback_set(
      w->mosq_, [](mosquitto*, void* u, int rc) { self(u)->on_disconnect(rc); });
  mosquitto_message_callback_set(w->mosq_, [](mosquitto*, void* u, const mosquitto_message* m) {
    if (m == nullptr || m->topic == nullptr) return;
    self(u)->on_message(m->topic,
                        std::string_view(static_cast<const char*>(m->payload),
                                         static_cast<std::size_t>(std::max(0, m->payloadlen))));
  });
  // the library's own thread reconnects with back-off (0.5 s doubling up to 5 s)
  mosquitto_reconnect_delay_set(w->mosq_, 1, 5, true);
  const int rc = mosquitto_connect_async(w->mosq_, broker.host.c_str(), broker.port, kKeepaliveS);
  if (rc != MOSQ_ERR_SUCCESS && w->log_) {
    w->log_(fmt::format("fleet: broker {}: {}; retrying", broker_label(broker),
                        detail::explain_failure(rc, errno, broker, false)));
  }
  const int lrc = mosquitto_loop_start(w->mosq_);
  if (lrc != MOSQ_ERR_SUCCESS) {
    return Error{kBadUrl, fmt::format("libmosquitto: {}", mosquitto_strerror(lrc))};
  }
  return w;
}

FleetWatcher::FleetWatcher(const BrokerAddress& broker, Log log)
    : broker_(broker), log_(std::move(log)) {}

FleetWatcher::~FleetWatcher() {
  if (mosq_ == nullptr) return;
  (void)mosquitto_disconnect(mosq_);
  (void)mosquitto_loop_stop(mosq_, true);
  mosquitto_destroy(mosq_);
}

void FleetWatcher::on_connect(int rc) {
  std::string say;
  {
    std::lock_guard<std::mutex> lock(mu_);
    if (rc != 0) {
      const std::string why =
          fmt::format("refused the connection: {}", mosquitto_connack_string(rc));
      if (why != last_problem_) say = why;
      last_problem_ = why;
    } else {
      connected_ = true;
      ++counters_.connects;
      if (counters_.connects == 1 || !last_problem_.empty()) say = "connected";
      last_problem_.clear();
    }
  }
  if (rc == 0) {
    const std::string prefix(kTopicPrefix);
    (void)mosquitto_subscribe(mosq_, nullptr, (prefix + "/+/state").c_str(), 0);
    (void)mosquitto_subscribe(mosq_, nullptr, (prefix + "/+/connection").c_str(), 1);
  }
  if (!say.empty() && log_) {
    log_(fmt::format("fleet: broker {} {}", broker_label(broker_), say));
  }
}

void FleetWatcher::on_disconnect(int rc) {
  bool answered = false;
  {
    std::lock_guard<std::mutex> lock(mu_);
    answered = connected_;
    connected_ = false;
  }
  if (rc == 0) return;
  // on the library's thread: a TLS failure is probed again here (a few seconds at most)
  const std::string why = detail::explain_failure(rc, errno, broker_, answered);
  bool news = false;
  {
    std::lock_guard<std::mutex> lock(mu_);
    news = why != last_problem_;
    last_problem_ = why;
  }
  if (news && log_) log_(fmt::format("fleet: broker {}: {}; retrying", broker_label(broker_), why));
}

void FleetWatcher::on_message(std::string_view topic, std::string_view payload) {
  // scaratwin/v1/<robot>/<leaf>
  const std::string prefix = std::string(kTopicPrefix) + "/";
  std::lock_guard<std::mutex> lock(mu_);
  if (topic.substr(0, prefix.size()) != prefix) {
    ++counters_.ignored;
    return;
  }
  const std::string_view rest = topic.substr(prefix.size());
  const std::size_t slash = rest.find('/');
  if (slash == std::string_view::npos) {
    ++counters_.ignored;
    return;
  }
  const std::string_view name = rest.substr(0, slash), leaf = rest.substr(slash + 1);
  if ((leaf != "state" && leaf != "connection") || !check_robot_name(name)) {
    ++counters_.ignored;
    return;
  }
  auto it = robots_.find(std::string(name));
  if (it == robots_.end()) {
    if (robots_.size() >= kMaxWatchedRobots) {
      ++counters_.ignored;
      return;
    }
    it = robots_.emplace(std::string(name), RobotView{}).first;
  }
  RobotView& r = it->second;
  if (leaf == "connection") {
    r.connection = payload == "online" || payload == "offline" ? std::string(payload) : "?";
    return;
  }
  if (payload.size() > kMaxStateBytes) {
    ++counters_.malformed;
    return;
  }
  const json j = json::parse(payload, nullptr, false);
  if (j.is_discarded() || !j.is_object()) {
    ++counters_.malformed;
    return;
  }
  r.state_json = j.dump();  // re-serialised: what reaches the page is well-formed JSON
  r.last_state = std::chrono::steady_clock::now();
  ++r.states;
  ++counters_.states;
}

bool FleetWatcher::connected() const {
  std::lock_guard<std::mutex> lock(mu_);
  return connected_;
}

WatchCounters FleetWatcher::counters() const {
  std::lock_guard<std::mutex> lock(mu_);
  return counters_;
}

std::map<std::string, RobotView> FleetWatcher::robots() const {
  std::lock_guard<std::mutex> lock(mu_);
  return robots_;
}

std::string FleetWatcher::snapshot_json() const {
  const auto now = std::chrono::steady_clock::now();
  json out;
  out["broker"] = broker_label(broker_);
  json list = json::array();
  std::lock_guard<std::mutex> lock(mu_);
  out["connected"] = connected_;
  for (const auto& [name, r] : robots_) {
    json e;
    e["name"] = name;
    e["connection"] = r.connection.empty() ? json(nullptr) : json(r.connection);
    e["states"] = r.states;
    if (r.state_json.empty()) {
      e["age_ms"] = nullptr;
      e["state"] = nullptr;
    } else {
      e["age_ms"] = std::chrono::duration<double, std::milli>(now - r.last_state).count();
      e["state"] = json::parse(r.state_json, nullptr, false);
    }
    list.push_back(std::move(e));
  }
  out["robots"] = std::move(list);
  return out.dump();
}

}  // namespace scaratwin::fleet
