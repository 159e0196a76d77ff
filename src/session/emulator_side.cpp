#include "scaratwin/session/emulator_side.hpp"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <ctime>
#include <sstream>
#include <utility>

#include <fmt/format.h>

namespace scaratwin::session {
namespace {

int connect_local(std::uint16_t port) {
  const int fd = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_port = htons(port);
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  if (fd < 0) return -1;
  if (::connect(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0) {
    ::close(fd);
    return -1;
  }
  return fd;
}

bool send_line(int fd, const std::string& line) {
  const std::string out = line + "\n";
  return ::send(fd, out.data(), out.size(), MSG_NOSIGNAL) == static_cast<ssize_t>(out.size());
}

// key=value pairs of a line
std::optional<std::string> field(const std::string& line, const char* key) {
  const std::string k = std::string(" ") + key + "=";
  const auto at = line.find(k);
  if (at == std::string::npos) return std::nullopt;
  const auto start = at + k.size();
  return line.substr(start, line.find(' ', start) - start);
}

}  // namespace

std::uint64_t monotonic_us() {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<std::uint64_t>(ts.tv_sec) * 1000000ULL +
         static_cast<std::uint64_t>(ts.tv_nsec) / 1000ULL;
}

std::optional<TruthSample> parse_truth_line(const std::string& line) {
  if (line.rfind("TR ", 0) != 0) return std::nullopt;
  TruthSample s;
  try {
    s.mono_us = std::stoull(field(line, "mono_us").value_or("0"));
    s.sim_us = std::stoull(field(line, "sim_us").value_or("0"));
    s.board_us = std::stoull(field(line, "board_us").value_or("0"));
    s.as_built = field(line, "plant").value_or("") == "as-built";
    if (s.as_built) {
      const char* qk[] = {"d1_m", "q2_rad", "q3_rad", "q4_rad"};
      for (int j = 0; j < 4; ++j) s.q[j] = std::stod(field(line, qk[j]).value());
      const char* tk[] = {"tool_x_m", "tool_y_m", "tool_z_m", "tool_yaw_rad"};
      for (int j = 0; j < 4; ++j) s.tool[j] = std::stod(field(line, tk[j]).value());
      const char* lk[] = {"lost_z", "lost_j2", "lost_j3"};
      for (int j = 0; j < 3; ++j) s.lost[j] = std::stoll(field(line, lk[j]).value());
      s.held = std::stoi(field(line, "held").value_or("-1"));
    }
  } catch (const std::exception&) {
    return std::nullopt;
  }
  return s;
}

Result<EmulatorSide> EmulatorSide::connect(std::uint16_t port) {
  EmulatorSide b;
  b.fd_ = connect_local(port);
  if (b.fd_ < 0) {
    return Error{AppError::kEmulatorChannel,
                 fmt::format("emulator side channel 127.0.0.1:{}: {}", port, std::strerror(errno))};
  }
  if (auto r = b.command("rate 0"); !r) return r.error();  // no truth lines, replies only
  return b;
}

EmulatorSide::EmulatorSide(EmulatorSide&& o) noexcept : fd_(std::exchange(o.fd_, -1)) {}
EmulatorSide::~EmulatorSide() {
  if (fd_ >= 0) ::close(fd_);
}

Result<std::string> EmulatorSide::command(const std::string& line) {
  if (!send_line(fd_, line))
    return Error{AppError::kEmulatorChannel, "emulator side channel: send failed"};
  std::string reply;
  char c = 0;
  while (reply.size() < 65536) {
    pollfd p{fd_, POLLIN, 0};
    if (::poll(&p, 1, 2000) != 1 || ::recv(fd_, &c, 1, 0) != 1) break;
    if (c != '\n') {
      reply.push_back(c);
      continue;
    }
    if (reply.rfind("ERR", 0) == 0) return Error{AppError::kEmulatorChannel, "emulator: " + reply};
    const bool is_truth = reply.rfind("TR ", 0) == 0;
    // a TR line sent before `rate 0` took effect is not the reply (unless we asked for one)
    if (!is_truth || line == "query") return reply;
    reply.clear();
  }
  return Error{AppError::kEmulatorChannel, "emulator side channel: no reply to '" + line + "'"};
}

Status EmulatorSide::press(const std::string& button, int ms) {
  auto r = command(fmt::format("press {} {}", button, ms));
  if (!r) return r.error();
  return Ok{};
}

Status EmulatorSide::place(CubeColor color, double x_m, double y_m) {
  auto r = command(fmt::format("place {} {:.6f} {:.6f}", color_name(color), x_m, y_m));
  if (!r) return r.error();
  return Ok{};
}

Status EmulatorSide::pattern(bool on) {
  auto r = command(on ? "pattern on" : "pattern off");
  if (!r) return r.error();
  return Ok{};
}

Status EmulatorSide::clear() {
  auto r = command("clear");
  if (!r) return r.error();
  return Ok{};
}

Result<std::vector<protocol::ObjectPose>> EmulatorSide::cubes() {
  auto r = command("cubes");
  if (!r) return r.error();
  std::istringstream in(*r);
  std::string word;
  std::size_t n = 0;
  in >> word >> n;
  if (word != "CUBES")
    return Error{AppError::kEmulatorChannel, "emulator: unexpected reply to cubes: " + *r};
  std::vector<protocol::ObjectPose> out;
  for (std::size_t i = 0; i < n && in >> word; ++i) {
    // id:colour:x:y:z
    std::vector<std::string> f;
    std::stringstream ws(word);
    for (std::string part; std::getline(ws, part, ':');) f.push_back(part);
    if (f.size() != 5) return Error{AppError::kEmulatorChannel, "emulator: bad cube in " + *r};
    auto colour = parse_color(f[1]);
    if (!colour) return Error{AppError::kEmulatorChannel, "emulator: bad colour in " + *r};
    protocol::ObjectPose o;
    o.id = std::stoi(f[0]);
    o.color = *colour;
    o.x_m = std::stod(f[2]);
    o.y_m = std::stod(f[3]);
    o.z_m = std::stod(f[4]);
    out.push_back(o);
  }
  return out;
}

Result<TruthSample> EmulatorSide::query() {
  auto r = command("query");
  if (!r) return r.error();
  auto s = parse_truth_line(*r);
  if (!s) return Error{AppError::kEmulatorChannel, "emulator: unexpected reply to query: " + *r};
  return *s;
}

Result<std::unique_ptr<TruthRecorder>> TruthRecorder::start(std::uint16_t port, double hz) {
  std::unique_ptr<TruthRecorder> t(new TruthRecorder());
  t->fd_ = connect_local(port);
  if (t->fd_ < 0 || !send_line(t->fd_, fmt::format("rate {}", hz))) {
    return Error{AppError::kEmulatorChannel,
                 fmt::format("emulator side channel 127.0.0.1:{}: cannot subscribe to the "
                             "truth",
                             port)};
  }
  TruthRecorder* self = t.get();
  t->thread_ = std::thread([self] {
    std::string buf;
    char chunk[4096];
    while (!self->stop_) {
      pollfd p{self->fd_, POLLIN, 0};
      if (::poll(&p, 1, 100) != 1) continue;
      const ssize_t n = ::recv(self->fd_, chunk, sizeof chunk, 0);
      if (n <= 0) break;
      buf.append(chunk, static_cast<std::size_t>(n));
      std::size_t nl;
      while ((nl = buf.find('\n')) != std::string::npos) {
        auto s = parse_truth_line(buf.substr(0, nl));
        buf.erase(0, nl + 1);
        if (s) {
          std::lock_guard lock(self->mutex_);
          self->samples_.push_back(*s);
        }
      }
    }
  });
  return t;
}

TruthRecorder::~TruthRecorder() {
  stop_ = true;
  if (thread_.joinable()) thread_.join();
  if (fd_ >= 0) ::close(fd_);
}

std::vector<TruthSample> TruthRecorder::between(std::uint64_t from_us, std::uint64_t to_us) const {
  std::lock_guard lock(mutex_);
  std::vector<TruthSample> out;
  for (const TruthSample& s : samples_) {
    if (s.mono_us >= from_us && s.mono_us <= to_us) out.push_back(s);
  }
  return out;
}

}  // namespace scaratwin::session
