// Test helpers for the fleet: a Mosquitto broker on a free loopback port (the real broker, a
// child process) and an MQTT client (libmosquitto) that records every message it sees.
#pragma once

#include <mosquitto.h>

#include <chrono>
#include <condition_variable>
#include <filesystem>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include <fmt/format.h>

#include "scaratwin/fleet/local_broker.hpp"
#include "scaratwin/fleet/mqtt_bridge.hpp"
#include "scaratwin/hub/process.hpp"

namespace scaratwin::test {

// A loopback port nobody listens on right now.
inline int free_loopback_port() {
  auto p = fleet::free_loopback_port();
  return p ? *p : 0;
}

// `mosquitto -c dir/mosquitto-PORT.conf` listening on 127.0.0.1:port (the product's own local
// broker, fleet/local_broker.hpp).
inline Result<std::unique_ptr<ChildProcess>> start_broker(const std::filesystem::path& exe,
                                                          const std::filesystem::path& dir,
                                                          int port) {
  auto b = fleet::start_local_broker(dir, static_cast<std::uint16_t>(port), exe);
  if (!b) return b.error();
  return std::move(b->process);
}

struct Message {
  std::string topic, payload;
  bool retain = false;
};

// How a Peer reaches a broker that asks more than a plain connection: TLS with `ca`, a user.
struct PeerAuth {
  std::string host = "127.0.0.1";
  std::string ca, user, password;
};

// An MQTT client that subscribes to `filter` and keeps what arrives.
class Peer {
 public:
  Peer(int port, const std::string& filter, const PeerAuth& auth = {}) {
    (void)fleet::init_mqtt_library();
    m_ = mosquitto_new(nullptr, true, this);
    if (!auth.ca.empty())
      mosquitto_tls_set(m_, auth.ca.c_str(), nullptr, nullptr, nullptr, nullptr);
    if (!auth.user.empty()) {
      mosquitto_username_pw_set(m_, auth.user.c_str(), auth.password.c_str());
    }
    mosquitto_message_callback_set(m_, [](mosquitto*, void* u, const mosquitto_message* msg) {
      auto* self = static_cast<Peer*>(u);
      std::lock_guard<std::mutex> lock(self->mu_);
      self->messages_.push_back({msg->topic,
                                 std::string(static_cast<const char*>(msg->payload),
                                             static_cast<std::size_t>(msg->payloadlen)),
                                 msg->retain});
      self->cv_.notify_all();
    });
    filter_ = filter;
    mosquitto_connect_callback_set(m_, [](mosquitto* m, void* u, int rc) {
      if (rc == 0) mosquitto_subscribe(m, nullptr, static_cast<Peer*>(u)->filter_.c_str(), 1);
    });
    ok_ = mosquitto_connect(m_, auth.host.c_str(), port, 10) == MOSQ_ERR_SUCCESS &&
          mosquitto_loop_start(m_) == MOSQ_ERR_SUCCESS;
  }
  ~Peer() {
    mosquitto_disconnect(m_);
    mosquitto_loop_stop(m_, false);
    mosquitto_destroy(m_);
  }
  bool ok() const { return ok_; }
  bool publish(const std::string& topic, const std::string& payload, bool retain = false) {
    return mosquitto_publish(m_, nullptr, topic.c_str(), static_cast<int>(payload.size()),
                             payload.data(), 1, retain) == MOSQ_ERR_SUCCESS;
  }
  // The first message after message number `from` on `topic` that satisfies `pred`.
  std::optional<Message> wait(const std::string& topic,
                              const std::function<bool(const Message&)>& pred,
                              std::chrono::milliseconds timeout, std::size_t from = 0) {
    std::unique_lock<std::mutex> lock(mu_);
    std::optional<Message> found;
    cv_.wait_for(lock, timeout, [&] {
      for (std::size_t i = from; i < messages_.size(); ++i) {
        if (messages_[i].topic == topic && pred(messages_[i])) {
          found = messages_[i];
          return true;
        }
      }
      return false;
    });
    return found;
  }
  std::size_t count() {
    std::lock_guard<std::mutex> lock(mu_);
    return messages_.size();
  }
  std::vector<Message> since(std::size_t from) {
    std::lock_guard<std::mutex> lock(mu_);
    return {messages_.begin() + static_cast<std::ptrdiff_t>(std::min(from, messages_.size())),
            messages_.end()};
  }

 private:
  mosquitto* m_ = nullptr;
  std::string filter_;
  bool ok_ = false;
  std::mutex mu_;
  std::condition_variable cv_;
  std::vector<Message> messages_;
};

}  // namespace scaratwin::test
