// Helpers shared by the hub's end-to-end tests: a folder of a test's own, a file's text, a
// program run to its end (exit status and output), and the port a simulator child process
// listens on.
#pragma once

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <chrono>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include "scaratwin/core/result.hpp"
#include "scaratwin/hub/process.hpp"

namespace scaratwin::test {

// An empty folder for a test: <temp>/scaratwin-<name>-<pid>, emptied first.
inline std::filesystem::path fresh_dir(const std::string& name) {
  const std::filesystem::path p =
      std::filesystem::temp_directory_path() / fmt::format("scaratwin-{}-{}", name, getpid());
  std::filesystem::remove_all(p);
  std::filesystem::create_directories(p);
  return p;
}

// The whole text of a file ("" when it cannot be read).
inline std::string slurp(const std::filesystem::path& p) {
  std::ifstream in(p);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

struct Outcome {
  int status = -1;
  std::string output;  // stdout and stderr, the last 200 lines
};

// Runs `exe` with `args` until it exits (stopped after `timeout`).
inline Outcome run_program(const std::filesystem::path& exe, const std::vector<std::string>& args,
                           std::chrono::milliseconds timeout = std::chrono::seconds(60)) {
  Outcome o;
  auto p = ChildProcess::start(exe, args);
  if (!p) {
    ADD_FAILURE() << p.error().message;
    return o;
  }
  o.status = (*p)->wait_exit(timeout);
  o.output = (*p)->output_tail(200);
  return o;
}

// The TCP port of a simulator started as a child (`scaratwin-sim --port 0`), from its line
// "listening on HOST:PORT (...)".
inline Result<std::uint16_t> simulator_port(
    ChildProcess& sim, std::chrono::milliseconds timeout = std::chrono::seconds(60)) {
  auto line = sim.wait_for_line("listening on", timeout);
  if (!line) return line.error();
  const std::size_t paren = line->find(" (");
  const std::size_t colon = line->rfind(':', paren);
  if (colon == std::string::npos || paren == std::string::npos || paren <= colon + 1) {
    return Error{error_code(HubError::kFailed), "no port in the simulator's line: " + *line};
  }
  return static_cast<std::uint16_t>(std::stoi(line->substr(colon + 1, paren - colon - 1)));
}

// One truth sample of an emulated robot (its side channel's TR line), key by key; empty when
// the side channel does not answer.
inline std::map<std::string, std::string> truth(int side_port) {
  std::map<std::string, std::string> t;
  const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_port = htons(static_cast<std::uint16_t>(side_port));
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  if (::connect(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0) {
    ::close(fd);
    return t;
  }
  const std::string cmd = "rate 0\nquery\n";
  ::send(fd, cmd.data(), cmd.size(), MSG_NOSIGNAL);
  std::string buf;
  char tmp[4096];
  for (;;) {
    const auto at = buf.find("\nTR ");
    const auto start = buf.rfind("TR ", 0) == 0 ? 0 : (at == std::string::npos ? at : at + 1);
    if (start != std::string::npos && buf.find('\n', start) != std::string::npos) {
      std::istringstream in(buf.substr(start, buf.find('\n', start) - start));
      std::string tok;
      while (in >> tok) {
        const auto eq = tok.find('=');
        if (eq != std::string::npos) t[tok.substr(0, eq)] = tok.substr(eq + 1);
      }
      break;
    }
    const ssize_t n = ::recv(fd, tmp, sizeof tmp, 0);
    if (n <= 0) break;
    buf.append(tmp, static_cast<std::size_t>(n));
  }
  ::close(fd);
  return t;
}

}  // namespace scaratwin::test
