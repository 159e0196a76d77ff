// SPDX-License-Identifier: GPL-3.0-or-later (scaratwin-robot emulator, see side_channel.hpp)
#include "side_channel.hpp"

#include <arpa/inet.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

namespace scaratwin::robot {

Result<SideChannel> SideChannel::listen(std::uint16_t port) {
  SideChannel sc;
  sc.listen_fd_ = ::socket(AF_INET, SOCK_STREAM | SOCK_NONBLOCK, 0);
  if (sc.listen_fd_ < 0)
    return Error{EmulatorError::kSideChannel, std::string("socket: ") + std::strerror(errno)};
  int one = 1;
  setsockopt(sc.listen_fd_, SOL_SOCKET, SO_REUSEADDR, &one, sizeof one);
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_port = htons(port);
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  if (::bind(sc.listen_fd_, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0) {
    return Error{EmulatorError::kSideChannel, "cannot listen on 127.0.0.1:" + std::to_string(port) +
                                                  ": " + std::strerror(errno) +
                                                  " (use --side-port 0 for a free port)"};
  }
  ::listen(sc.listen_fd_, 8);
  socklen_t len = sizeof addr;
  getsockname(sc.listen_fd_, reinterpret_cast<sockaddr*>(&addr), &len);
  sc.port_ = ntohs(addr.sin_port);
  return sc;
}

SideChannel::SideChannel(SideChannel&& other) noexcept
    : listen_fd_(other.listen_fd_),
      port_(other.port_),
      clients_(std::move(other.clients_)),
      blocking_(other.blocking_) {
  other.listen_fd_ = -1;
  other.clients_.clear();
}

SideChannel::~SideChannel() {
  for (auto& c : clients_)
    if (c.fd >= 0) ::close(c.fd);
  if (listen_fd_ >= 0) ::close(listen_fd_);
}

std::vector<int> SideChannel::client_fds() const {
  std::vector<int> fds;
  for (const auto& c : clients_) fds.push_back(c.fd);
  return fds;
}

void SideChannel::write_all(Client& c, const std::string& data) {
  if (c.fd < 0) return;
  std::size_t off = 0;
  while (off < data.size()) {
    const ssize_t n = ::send(c.fd, data.data() + off, data.size() - off, MSG_NOSIGNAL);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      if (n < 0 && errno == EAGAIN && blocking_) {
        // a reply that must arrive whole (a camera frame): wait for the client to read
        pollfd p{c.fd, POLLOUT, 0};
        if (::poll(&p, 1, 2000) == 1) continue;
      }
      if (n < 0 && errno == EAGAIN && !blocking_) return;  // a slow client loses samples
      ::close(c.fd);
      c.fd = -1;
      return;
    }
    off += static_cast<std::size_t>(n);
  }
}

void SideChannel::poll(const CommandHandler& handler) {
  for (;;) {
    const int fd = ::accept4(listen_fd_, nullptr, nullptr, SOCK_NONBLOCK);
    if (fd < 0) break;
    int one = 1;
    setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
    clients_.push_back(Client{fd, {}, 100.0, 0});
  }
  for (std::size_t i = 0; i < clients_.size(); ++i) {
    Client& c = clients_[i];
    if (c.fd < 0) continue;
    char buf[1024];
    for (;;) {
      const ssize_t n = ::recv(c.fd, buf, sizeof buf, 0);
      if (n == 0 || (n < 0 && errno != EAGAIN && errno != EINTR)) {
        ::close(c.fd);
        c.fd = -1;
        break;
      }
      if (n < 0) break;
      c.in.append(buf, static_cast<std::size_t>(n));
    }
    std::size_t nl;
    while (clients_[i].fd >= 0 && (nl = clients_[i].in.find('\n')) != std::string::npos) {
      std::string line = clients_[i].in.substr(0, nl);
      clients_[i].in.erase(0, nl + 1);
      if (!line.empty() && line.back() == '\r') line.pop_back();
      if (line.empty()) continue;
      const std::string reply = handler(line, static_cast<int>(i));
      write_all(clients_[i], reply + "\n");
    }
  }
  std::erase_if(clients_, [](const Client& c) { return c.fd < 0; });
}

void SideChannel::publish(std::uint64_t mono_us, const std::function<std::string()>& make_line) {
  std::string line;
  for (auto& c : clients_) {
    if (c.rate_hz <= 0 || mono_us < c.next_us) continue;
    const auto period = static_cast<std::uint64_t>(1e6 / c.rate_hz);
    c.next_us =
        c.next_us == 0 || mono_us - c.next_us > period ? mono_us + period : c.next_us + period;
    if (line.empty()) line = make_line() + "\n";
    write_all(c, line);
  }
}

void SideChannel::send_to(int client, const std::string& line) {
  if (client >= 0 && client < static_cast<int>(clients_.size()))
    write_all(clients_[client], line + "\n");
}

void SideChannel::set_rate(int client, double hz) {
  if (client >= 0 && client < static_cast<int>(clients_.size())) clients_[client].rate_hz = hz;
}

}  // namespace scaratwin::robot
