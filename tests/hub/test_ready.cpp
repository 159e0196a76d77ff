// Our programs started through their ready descriptor (docs/firmware.md, --ready-fd): the one
// JSON line says where each serves, checked against the programs' own text output (written for
// people) and by reaching each port; a program that ends before it is ready is said with its
// last words; a ready line that is not one is refused naming what is wrong.
#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <string>

#include <gtest/gtest.h>

#include "hub_test_support.hpp"
#include "scaratwin/core/error_codes.hpp"
#include "scaratwin/hub/process.hpp"

namespace scaratwin {
namespace {

namespace fs = std::filesystem;
using namespace std::chrono_literals;

const fs::path kBin = SCARATWIN_BIN_DIR;

// The text after `key` on the line of `process`'s output that holds it.
std::string printed(ChildProcess& process, const std::string& key) {
  auto line = process.wait_for_line(key, 5s);
  EXPECT_TRUE(line) << line.error().message;
  if (!line) return {};
  return line->substr(line->find(key) + key.size());
}

// Sends `command` to a TCP port on 127.0.0.1 and returns the first line of the answer.
std::string ask(std::uint16_t port, const std::string& command) {
  const int fd = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_port = htons(port);
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  if (::connect(fd, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0) {
    ::close(fd);
    return "(no connection)";
  }
  const std::string out = command + "\n";
  (void)!::send(fd, out.data(), out.size(), MSG_NOSIGNAL);
  std::string in;
  char buf[1024];
  pollfd p{fd, POLLIN, 0};
  while (in.find('\n') == std::string::npos && ::poll(&p, 1, 5000) > 0) {
    const ssize_t n = ::recv(fd, buf, sizeof buf, 0);
    if (n <= 0) break;
    in.append(buf, static_cast<std::size_t>(n));
  }
  ::close(fd);
  return in.substr(0, in.find('\n'));
}

TEST(ReadyFd, TheEmulatorSaysItsPtyAndPortsOnItsReadyLine) {
  const fs::path dir = test::fresh_dir("ready-robot");
  auto r = start_emulator(
      kBin / "scaratwin-robot",
      {"--speed", "1", "--plant", "ideal", "--camera-port", "-1", "--exit-with-parent"},
      dir / "robot.log", 30s);
  ASSERT_TRUE(r) << r.error().message;
  ChildProcess& p = *r->process;
  // the same as it tells a person
  EXPECT_EQ(r->ready.pty, printed(p, "pty: "));
  EXPECT_EQ(std::to_string(r->ready.side_port), printed(p, "side channel: 127.0.0.1:"));
  EXPECT_EQ(r->ready.plant, "ideal");
  EXPECT_EQ(r->ready.camera_port, 0);
  // and each is what it says: the pty a terminal device, the side channel answering
  struct stat st {};
  ASSERT_EQ(::stat(r->ready.pty.c_str(), &st), 0) << r->ready.pty;
  EXPECT_TRUE(S_ISCHR(st.st_mode));
  EXPECT_EQ(ask(r->ready.side_port, "query").rfind("TR ", 0), 0u);
  // read once, the line stays
  auto again = p.wait_ready(1s);
  ASSERT_TRUE(again);
  EXPECT_EQ(parse_emulator_ready(*again)->pty, r->ready.pty);
}

TEST(ReadyFd, TheSimulatorSaysItsPortOnItsReadyLine) {
  const fs::path dir = test::fresh_dir("ready-sim");
  auto s =
      start_simulator(kBin / "scaratwin-sim", {"--port", "0", "--http-port", "0", "--no-camera"},
                      dir / "sim.log", 30s);
  ASSERT_TRUE(s) << s.error().message;
  const std::string listening = printed(*s->process, "listening on 127.0.0.1:");
  EXPECT_EQ(listening.substr(0, listening.find(' ')), std::to_string(s->ready.port));
  EXPECT_TRUE(s->ready.ui_url.empty());  // --http-port 0: no browser view
  EXPECT_EQ(s->ready.companion_port, 0);
  // the port serves the protocol: an unknown code is answered with its error (ER 3)
  EXPECT_EQ(ask(s->ready.port, "XX,").rfind("ER,3,", 0), 0u);
}

TEST(ReadyFd, AProgramThatEndsBeforeItIsReadyIsSaidWithItsLastWords) {
  const fs::path dir = test::fresh_dir("ready-fails");
  auto r = start_emulator(kBin / "scaratwin-robot", {"--plant", "wooden"}, dir / "robot.log", 30s);
  ASSERT_FALSE(r);
  EXPECT_EQ(r.error().code, error_code(HubError::kExited));
  EXPECT_NE(r.error().message.find("scaratwin-robot exited before it was ready"), std::string::npos)
      << r.error().message;
  EXPECT_NE(r.error().message.find("wooden"), std::string::npos) << r.error().message;
  // a child that never got a ready descriptor has no ready line to wait for
  auto plain = ChildProcess::start("/bin/sleep", {"5"});
  ASSERT_TRUE(plain);
  auto none = (*plain)->wait_ready(100ms);
  ASSERT_FALSE(none);
  EXPECT_EQ(none.error().code, error_code(HubError::kNotReady));
}

TEST(ReadyFd, ALineThatIsNotAReadyLineIsRefusedNamingWhy) {
  auto not_json = parse_emulator_ready("pty: /dev/pts/3");
  ASSERT_FALSE(not_json);
  EXPECT_NE(not_json.error().message.find("not a JSON object"), std::string::npos);
  auto other = parse_emulator_ready(R"({"program":"scaratwin-sim","port":5})");
  ASSERT_FALSE(other);
  EXPECT_NE(other.error().message.find("another program's"), std::string::npos);
  auto no_pty = parse_emulator_ready(R"({"program":"scaratwin-robot","side_port":5})");
  ASSERT_FALSE(no_pty);
  EXPECT_NE(no_pty.error().message.find("no pty"), std::string::npos);
  auto big = parse_simulator_ready(R"({"program":"scaratwin-sim","port":70000})");
  ASSERT_FALSE(big);
  EXPECT_NE(big.error().message.find("no port 'port' (0..65535)"), std::string::npos);
  auto ok = parse_simulator_ready(
      R"({"program":"scaratwin-sim","port":55016,"ui_url":"http://127.0.0.1:8080/"})");
  ASSERT_TRUE(ok);
  EXPECT_EQ(ok->port, 55016);
  EXPECT_EQ(ok->ui_url, "http://127.0.0.1:8080/");
  EXPECT_EQ(ok->companion_port, 0);
}

}  // namespace
}  // namespace scaratwin
