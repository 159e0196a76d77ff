// A Mosquitto of our own on this machine, for `scaratwin demo --mqtt` with no broker given and
// for the fleet tests and benchmark: `mosquitto -c DIR/mosquitto-PORT.conf` listening on
// 127.0.0.1 only, anonymous, no persistence, TCP_NODELAY (docs/fleet.md), its log in
// DIR/broker-PORT.log. Stopped when the returned object goes away.
#pragma once

#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>

#include "scaratwin/core/result.hpp"
#include "scaratwin/hub/process.hpp"

namespace scaratwin::fleet {

struct LocalBroker {
  std::unique_ptr<ChildProcess> process;
  std::uint16_t port = 0;
  std::string url;  // mqtt://127.0.0.1:PORT
};

// The mosquitto executable: on PATH or in /usr/sbin, /usr/local/sbin (Debian installs it in
// /usr/sbin, which a user's PATH may lack); the error says which package to install.
Result<std::filesystem::path> find_mosquitto();

// A free TCP port on 127.0.0.1 (taken from the kernel, then released).
Result<std::uint16_t> free_loopback_port();

// Starts the broker on `port` (0: a free one) and waits until it runs (at most 20 s). `exe`
// empty: find_mosquitto().
Result<LocalBroker> start_local_broker(const std::filesystem::path& dir, std::uint16_t port = 0,
                                       std::filesystem::path exe = {});

}  // namespace scaratwin::fleet
