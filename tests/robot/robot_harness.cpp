#include "robot_harness.hpp"

#include <arpa/inet.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <poll.h>
#include <signal.h>
#include <spawn.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <termios.h>
#include <unistd.h>

#include <algorithm>
#include <cstdlib>
#include <cstring>
#include <sstream>

extern char** environ;

namespace scaratwin::test {
namespace {

double now_s() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

// Reads one '\n'-terminated line from fd into buf (non-blocking fd), waiting up to timeout.
std::optional<std::string> read_line(int fd, std::string& buf, double timeout_s) {
  const double end = now_s() + timeout_s;
  for (;;) {
    const auto nl = buf.find('\n');
    if (nl != std::string::npos) {
      std::string l = buf.substr(0, nl);
      buf.erase(0, nl + 1);
      return l;
    }
    const double left = end - now_s();
    if (left <= 0) return std::nullopt;
    pollfd p{fd, POLLIN, 0};
    if (poll(&p, 1, static_cast<int>(left * 1000) + 1) <= 0) continue;
    char tmp[4096];
    const ssize_t n = ::read(fd, tmp, sizeof tmp);
    if (n > 0) buf.append(tmp, static_cast<std::size_t>(n));
    if (n == 0) return std::nullopt;
  }
}

}  // namespace

std::int64_t Truth::i(const std::string& key) const {
  auto it = fields.find(key);
  return it == fields.end() ? INT64_MIN : std::strtoll(it->second.c_str(), nullptr, 10);
}
std::uint64_t Truth::u(const std::string& key) const {
  auto it = fields.find(key);
  return it == fields.end() ? 0 : std::strtoull(it->second.c_str(), nullptr, 10);
}
std::pair<std::uint64_t, std::uint64_t> Truth::span(const std::string& axis) const {
  auto it = fields.find("span_" + axis);
  if (it == fields.end()) return {0, 0};
  const auto colon = it->second.find(':');
  return {std::strtoull(it->second.substr(0, colon).c_str(), nullptr, 10),
          std::strtoull(it->second.substr(colon + 1).c_str(), nullptr, 10)};
}

std::optional<Report> parse_report(const std::string& line) {
  if (line.rfind("ST=", 0) != 0) return std::nullopt;
  Report r;
  std::size_t pos = 3;
  for (int k = 0; k < 9; ++k) {
    const auto eq = line.find('=', pos);
    if (eq == std::string::npos) return std::nullopt;
    r.v[k] = std::strtoll(line.substr(pos, eq - pos).c_str(), nullptr, 10);
    pos = eq + 1;
  }
  return r;
}

Robot::Robot(const std::vector<std::string>& args) {
  int out[2];
  if (pipe(out) != 0) {
    error_ = "pipe failed";
    return;
  }
  posix_spawn_file_actions_t fa;
  posix_spawn_file_actions_init(&fa);
  posix_spawn_file_actions_adddup2(&fa, out[1], 1);
  posix_spawn_file_actions_addclose(&fa, out[0]);
  // the exact robot unless asked for the one as built: these tests check the firmware's
  // counts against the pins step for step
  const bool as_built = std::find(args.begin(), args.end(), "as-built") != args.end();
  std::vector<std::string> argv_s{SCARATWIN_ROBOT_EXE, "--firmware", SCARATWIN_FIRMWARE_ELF,
                                  "--exit-with-parent"};
  if (!as_built) argv_s.insert(argv_s.end(), {"--plant", "ideal"});
  argv_s.insert(argv_s.end(), args.begin(), args.end());
  std::vector<char*> argv;
  for (auto& s : argv_s) argv.push_back(s.data());
  argv.push_back(nullptr);
  if (posix_spawn(&pid_, argv[0], &fa, nullptr, argv.data(), environ) != 0) {
    error_ = std::string("cannot start ") + SCARATWIN_ROBOT_EXE;
    pid_ = -1;
  }
  posix_spawn_file_actions_destroy(&fa);
  ::close(out[1]);
  out_fd_ = out[0];
  if (pid_ < 0) return;
  std::string buf, pty_path;
  int port = -1;
  while (pty_path.empty() || port < 0 || (as_built && camera_port_ < 0)) {
    auto l = read_line(out_fd_, buf, 30.0);
    if (!l) {
      error_ = "the emulator printed no pty / side channel / camera";
      return;
    }
    if (l->rfind("pty: ", 0) == 0) pty_path = l->substr(5);
    if (l->rfind("side channel: ", 0) == 0) port = std::atoi(l->substr(l->rfind(':') + 1).c_str());
    if (l->rfind("camera: ", 0) == 0) {
      camera_port_ = std::atoi(l->substr(l->rfind(':') + 1).c_str());
    }
  }
  // open the port like a serial device: raw, no echo, input flushed
  pty_fd_ = ::open(pty_path.c_str(), O_RDWR | O_NOCTTY | O_NONBLOCK);
  if (pty_fd_ < 0) {
    error_ = "cannot open " + pty_path;
    return;
  }
  termios tio{};
  tcgetattr(pty_fd_, &tio);
  cfmakeraw(&tio);
  cfsetspeed(&tio, B115200);
  tcsetattr(pty_fd_, TCSANOW, &tio);
  tcflush(pty_fd_, TCIFLUSH);
  side_fd_ = ::socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_port = htons(static_cast<std::uint16_t>(port));
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  if (::connect(side_fd_, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0) {
    error_ = "cannot connect to the side channel";
    return;
  }
  fcntl(side_fd_, F_SETFL, O_NONBLOCK);
  if (side("rate 0").rfind("OK", 0) != 0) {
    error_ = "side channel does not answer";
    return;
  }
  // the firmware says hello once after reset, maybe before the flush above; a host asks
  // again until it answers (a real board also needs 1.5-2 s in its bootloader)
  bool hello = wait_for("HI=", 1.0).has_value();
  for (int attempt = 0; !hello && attempt < 30; ++attempt) {
    send("HI=1=\n");
    hello = wait_for("HI=", 1.0).has_value();
  }
  if (!hello) {
    error_ = "no hello from the firmware";
    return;
  }
  ok_ = true;
}

Robot::~Robot() {
  if (camera_fd_ >= 0) ::close(camera_fd_);
  if (pty_fd_ >= 0) ::close(pty_fd_);
  if (side_fd_ >= 0) ::close(side_fd_);
  if (pid_ > 0) {
    ::kill(pid_, SIGTERM);
    int status = 0;
    ::waitpid(pid_, &status, 0);
  }
  if (out_fd_ >= 0) ::close(out_fd_);
}

void Robot::power_off() {
  if (pid_ > 0) {
    ::kill(pid_, SIGKILL);
    int status = 0;
    ::waitpid(pid_, &status, 0);
    pid_ = -1;
  }
  ok_ = false;
}

void Robot::send(const std::string& bytes) {
  std::size_t off = 0;
  while (off < bytes.size()) {
    const ssize_t n = ::write(pty_fd_, bytes.data() + off, bytes.size() - off);
    if (n > 0) {
      off += static_cast<std::size_t>(n);
    } else {
      pollfd p{pty_fd_, POLLOUT, 0};
      poll(&p, 1, 100);
    }
  }
}

std::optional<std::string> Robot::read_line_raw(double timeout_s) {
  return read_line(pty_fd_, pty_buf_, timeout_s);
}

std::optional<std::string> Robot::line(double timeout_s, bool keep_reports) {
  const double end = now_s() + timeout_s;
  for (;;) {
    const double left = end - now_s();
    if (left <= 0) return std::nullopt;
    auto l = read_line_raw(left);
    if (!l) return std::nullopt;
    if (!keep_reports && l->rfind("ST=", 0) == 0) {
      reports.push_back(*l);
      continue;
    }
    return l;
  }
}

std::optional<std::string> Robot::wait_for(const std::string& prefix, double timeout_s,
                                           std::vector<std::string>* skipped) {
  const double end = now_s() + timeout_s;
  for (;;) {
    auto l = line(end - now_s(), prefix.rfind("ST", 0) == 0);
    if (!l) return std::nullopt;
    if (l->rfind(prefix, 0) == 0) return l;
    if (skipped) skipped->push_back(*l);
  }
}

std::optional<std::string> Robot::request(const std::string& packet, double timeout_s) {
  send(packet);
  return line(timeout_s);
}

std::optional<Report> Robot::query_state(double timeout_s) {
  send("QS=\n");
  // the periodic reports may come first: take the last report that arrives before the
  // reply to the next PI, i.e. the QS one
  send("PI=424242=\n");
  std::optional<Report> last;
  const double end = now_s() + timeout_s;
  for (;;) {
    auto l = line(end - now_s(), true);
    if (!l) return std::nullopt;
    if (auto r = parse_report(*l)) last = r;
    if (*l == "AK=PI=424242=") return last;
  }
}

bool Robot::home(double timeout_s) {
  auto ak = request("HM=\n");
  if (!ak || *ak != "AK=HM=") return false;
  return wait_for("EV=1=", timeout_s).has_value();
}

std::optional<std::string> Robot::side_line(double timeout_s) {
  return read_line(side_fd_, side_buf_, timeout_s);
}

std::string Robot::side(const std::string& command, double timeout_s) {
  const std::string msg = command + "\n";
  if (::send(side_fd_, msg.data(), msg.size(), MSG_NOSIGNAL) < 0) return "ERR send";
  for (;;) {
    auto l = side_line(timeout_s);
    if (!l) return "ERR timeout";
    if (l->rfind("TR ", 0) == 0 && command != "query") continue;  // a streamed sample
    return *l;
  }
}

Truth Robot::truth() {
  Truth t;
  std::istringstream in(side("query"));
  std::string tok;
  in >> tok;
  while (in >> tok) {
    const auto eq = tok.find('=');
    if (eq != std::string::npos) t.fields[tok.substr(0, eq)] = tok.substr(eq + 1);
  }
  return t;
}

std::string Robot::grab(int width, int height, std::vector<std::uint8_t>& rgb, double timeout_s) {
  rgb.clear();
  if (camera_port_ < 0) return "no camera";
  if (camera_fd_ < 0) {
    camera_fd_ = ::socket(AF_INET, SOCK_STREAM, 0);
    sockaddr_in addr{};
    addr.sin_family = AF_INET;
    addr.sin_port = htons(static_cast<std::uint16_t>(camera_port_));
    addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    if (::connect(camera_fd_, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0) {
      return "cannot connect to the camera";
    }
    fcntl(camera_fd_, F_SETFL, O_NONBLOCK);
  }
  const std::string cmd = "grab " + std::to_string(width) + " " + std::to_string(height) + "\n";
  if (::send(camera_fd_, cmd.data(), cmd.size(), MSG_NOSIGNAL) !=
      static_cast<ssize_t>(cmd.size())) {
    return "cannot send to the camera";
  }
  auto header = read_line(camera_fd_, camera_buf_, timeout_s);
  if (!header) return "no answer from the camera";
  if (header->rfind("FRAME ", 0) != 0) return *header;
  std::istringstream in(header->substr(6));
  std::uint64_t n = 0, sim_us = 0, bytes = 0;
  int w = 0, h = 0;
  in >> n >> sim_us >> w >> h >> bytes;
  const double end = now_s() + timeout_s;
  while (camera_buf_.size() < bytes + 1 && now_s() < end) {
    pollfd p{camera_fd_, POLLIN, 0};
    if (poll(&p, 1, 100) <= 0) continue;
    char tmp[65536];
    const ssize_t got = ::read(camera_fd_, tmp, sizeof tmp);
    if (got <= 0) break;
    camera_buf_.append(tmp, static_cast<std::size_t>(got));
  }
  if (camera_buf_.size() < bytes + 1) return "the frame was cut short";
  rgb.assign(camera_buf_.begin(), camera_buf_.begin() + static_cast<std::ptrdiff_t>(bytes));
  camera_buf_.erase(0, bytes + 1);
  return *header;
}

}  // namespace scaratwin::test
