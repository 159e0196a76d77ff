// docs/security.md's promises for a simulator listening beyond this machine, on the real
// program (`scaratwin-sim --bind 0.0.0.0`): without a token given it generates one (128 bits)
// and prints it; a hello with another token is refused and one with it admitted; the paper's
// companion port stays on 127.0.0.1 whatever --bind says (its scripts send no token), judged
// by the kernel's own table of listening sockets (/proc/net/tcp); and a connection that says
// nothing is closed after 10 s.
#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <chrono>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "scaratwin/hub/process.hpp"

namespace scaratwin {
namespace {

namespace fs = std::filesystem;
using namespace std::chrono_literals;

// A TCP connection to 127.0.0.1:port; each reply read within `timeout`.
class Client {
 public:
  explicit Client(int port) {
    fd_ = ::socket(AF_INET, SOCK_STREAM, 0);
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_port = htons(static_cast<std::uint16_t>(port));
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    ok_ = ::connect(fd_, reinterpret_cast<sockaddr*>(&a), sizeof a) == 0;
    timeval tv{0, 200000};
    ::setsockopt(fd_, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof tv);
  }
  ~Client() { ::close(fd_); }
  bool ok() const { return ok_; }
  void send(const std::string& s) { (void)::send(fd_, s.data(), s.size(), MSG_NOSIGNAL); }
  // The first line, or "" when none came within `timeout` ("<closed>" when the peer closed).
  std::string line(std::chrono::milliseconds timeout = 5000ms) {
    const auto end = std::chrono::steady_clock::now() + timeout;
    while (got_.find('\n') == std::string::npos && std::chrono::steady_clock::now() < end) {
      char buf[512];
      const ssize_t n = ::recv(fd_, buf, sizeof buf, 0);
      if (n == 0) return "<closed>";
      if (n > 0) got_.append(buf, static_cast<std::size_t>(n));
    }
    const auto nl = got_.find('\n');
    if (nl == std::string::npos) return "";
    std::string l = got_.substr(0, nl);
    got_.erase(0, nl + 1);
    return l;
  }

 private:
  int fd_ = -1;
  bool ok_ = false;
  std::string got_;
};

// The local address (hex, as the kernel writes it: 0100007F is 127.0.0.1) of the IPv4 socket
// listening on `port`, from /proc/net/tcp; "" when none listens there.
std::string listening_address(int port) {
  std::ifstream in("/proc/net/tcp");
  std::string line;
  std::getline(in, line);  // the header
  while (std::getline(in, line)) {
    std::istringstream f(line);
    std::string slot, local, remote, state;
    f >> slot >> local >> remote >> state;
    const auto colon = local.find(':');
    if (state != "0A" || colon == std::string::npos) continue;  // 0A: LISTEN
    if (std::stoi(local.substr(colon + 1), nullptr, 16) == port) return local.substr(0, colon);
  }
  return "";
}

TEST(Exposed, ATokenIsGeneratedAndPrintedAndTheCompanionPortStaysOnLoopback) {
  const fs::path dir = fs::temp_directory_path() / fmt::format("scaratwin-exposed-{}", getpid());
  fs::create_directories(dir);
  ::unsetenv("SCARATWIN_TOKEN");
  auto sim = ChildProcess::start(fs::path(SCARATWIN_BIN_DIR) / "scaratwin-sim",
                                 {"--bind", "0.0.0.0", "--port", "0", "--http-port", "0",
                                  "--no-camera", "--companion-port", "0"},
                                 dir / "sim.log", true);
  ASSERT_TRUE(sim) << sim.error().message;
  auto ready = (*sim)->wait_ready(60s);
  ASSERT_TRUE(ready) << ready.error().message;
  const auto j = nlohmann::json::parse(*ready);
  const int port = j.at("port").get<int>();
  const int companion = j.at("companion_port").get<int>();

  // the token: printed at start, 128 bits as 32 hex digits
  auto said = (*sim)->wait_for_line("listening beyond this machine: access token ", 10s);
  ASSERT_TRUE(said) << (*sim)->output_tail();
  const std::string head = "scaratwin-sim: listening beyond this machine: access token ";
  const std::string tail =
      " (give it to the hub with --sim-token or SCARATWIN_TOKEN, to the browser as ?token=)";
  const std::size_t at = said->find(head);
  ASSERT_NE(at, std::string::npos) << *said;
  const std::string token = said->substr(at + head.size(), 32);
  EXPECT_EQ(token.find_first_not_of("0123456789abcdef"), std::string::npos) << *said;
  EXPECT_EQ(token.size(), 32u) << *said;
  EXPECT_EQ(said->substr(at + head.size() + 32), tail) << *said;

  // the kernel's word on where each listens: the link on every address, the companion on
  // 127.0.0.1 only
  EXPECT_EQ(listening_address(port), "00000000");
  EXPECT_EQ(listening_address(companion), "0100007F");

  {
    Client wrong(port);
    ASSERT_TRUE(wrong.ok());
    wrong.send(fmt::format("HI,1,control,{},\n", token == std::string(32, 'a') ? "b" : "a"));
    EXPECT_EQ(wrong.line(), "ER,18,1,");
    EXPECT_EQ(wrong.line(), "<closed>");
  }
  {
    Client none(port);
    none.send("PI,1,\n");
    EXPECT_EQ(none.line(), "ER,18,1,");
  }
  Client hub(port);
  hub.send(fmt::format("HI,1,control,{},\nPI,7,\n", token));
  EXPECT_EQ(hub.line().substr(0, 19), "HI,1,scaratwin-sim,");
  EXPECT_EQ(hub.line(), "AK,PI,7,");

  // docs/security.md: "A connection must send its first line within 10 s, or it is closed"
  Client silent(port);
  ASSERT_TRUE(silent.ok());
  EXPECT_EQ(silent.line(8s), "") << "still open after 8 s";
  EXPECT_EQ(silent.line(12s), "<closed>") << "closed after 10 s";
  EXPECT_TRUE((*sim)->wait_for_line("no complete line within 10 s", 5s));
}

}  // namespace
}  // namespace scaratwin
