#include "scaratwin/fleet/local_broker.hpp"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <sstream>

#include <fmt/format.h>

#include "scaratwin/fleet/topics.hpp"

namespace scaratwin::fleet {

Result<std::filesystem::path> find_mosquitto() {
  std::string dirs = std::getenv("PATH") != nullptr ? std::getenv("PATH") : "";
  dirs += ":/usr/sbin:/usr/local/sbin";
  std::istringstream in(dirs);
  for (std::string d; std::getline(in, d, ':');) {
    if (d.empty()) continue;
    const std::filesystem::path p = std::filesystem::path(d) / "mosquitto";
    if (::access(p.c_str(), X_OK) == 0) return p;
  }
  return Error{
      kBadUrl,
      "no MQTT broker given and no mosquitto to start: install the Debian package "
      "mosquitto (scripts/install-deps.sh) or give --mqtt mqtt://HOST[:PORT] (or mqtts://)"};
}

Result<std::uint16_t> free_loopback_port() {
  const int fd = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
  if (fd < 0) return Error{kBadUrl, fmt::format("socket: {}", std::strerror(errno))};
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  socklen_t len = sizeof addr;
  if (::bind(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0 ||
      ::getsockname(fd, reinterpret_cast<sockaddr*>(&addr), &len) != 0) {
    const int e = errno;
    ::close(fd);
    return Error{kBadUrl, fmt::format("no free port on 127.0.0.1: {}", std::strerror(e))};
  }
  ::close(fd);
  return static_cast<std::uint16_t>(ntohs(addr.sin_port));
}

Result<LocalBroker> start_local_broker(const std::filesystem::path& dir, std::uint16_t port,
                                       std::filesystem::path exe) {
  if (exe.empty()) {
    auto found = find_mosquitto();
    if (!found) return found.error();
    exe = *found;
  }
  if (port == 0) {
    auto p = free_loopback_port();
    if (!p) return p.error();
    port = *p;
  }
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  const auto conf = dir / fmt::format("mosquitto-{}.conf", port);
  {
    std::ofstream c(conf);
    c << fmt::format(
        "listener {} 127.0.0.1\nallow_anonymous true\npersistence false\nset_tcp_nodelay true\n"
        "log_dest stderr\nlog_type error\nlog_type warning\nlog_type notice\n"
        "log_type information\n",
        port);
    if (!c) return Error{kBadUrl, fmt::format("cannot write {}", conf.string())};
  }
  auto b =
      ChildProcess::start(exe, {"-c", conf.string()}, dir / fmt::format("broker-{}.log", port));
  if (!b) return b.error();
  if (auto l = (*b)->wait_for_line(" running", std::chrono::seconds(20)); !l) {
    return Error{kBadUrl, fmt::format("mosquitto on 127.0.0.1:{}: {}", port, l.error().message)};
  }
  LocalBroker out;
  out.process = std::move(*b);
  out.port = port;
  out.url = fmt::format("mqtt://127.0.0.1:{}", port);
  return out;
}

}  // namespace scaratwin::fleet
