#include "scaratwin/session/port_owner.hpp"

#include <fcntl.h>
#include <poll.h>
#include <sys/file.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstdlib>
#include <cstring>
#include <mutex>

#include <fmt/format.h>

#include <nlohmann/json.hpp>

#include "scaratwin/hub/runner.hpp"

namespace scaratwin::session {
namespace {

namespace fs = std::filesystem;

constexpr std::size_t kMaxRequestBytes = 1 << 20;  // a script of some thousand lines

// $XDG_RUNTIME_DIR/scaratwin (the user's own, cleared at logout), else /tmp/scaratwin-UID.
fs::path owner_dir() {
  const char* xdg = std::getenv("XDG_RUNTIME_DIR");
  std::error_code ec;
  if (xdg != nullptr && *xdg != '\0' && fs::is_directory(xdg, ec)) {
    return fs::path(xdg) / "scaratwin";
  }
  return fs::path(fmt::format("/tmp/scaratwin-{}", ::getuid()));
}

// The port's name in the folder: its real path with '/' as '_' (dev_ttyACM0, dev_pts_7); a
// name too long for a socket's address is cut and made unique by a hash.
std::string port_name(const std::string& device) {
  std::error_code ec;
  fs::path real = fs::canonical(device, ec);
  if (ec) real = fs::absolute(device, ec);
  std::string name = real.string();
  while (!name.empty() && name.front() == '/') name.erase(0, 1);
  for (char& c : name) {
    if (c == '/') c = '_';
  }
  if (name.size() > 60) {
    name = fmt::format("{}-{:016x}", name.substr(name.size() - 40),
                       std::hash<std::string>{}(real.string()));
  }
  return name;
}

Status write_all(int fd, const std::string& text) {
  std::size_t done = 0;
  while (done < text.size()) {
    const ssize_t n = ::send(fd, text.data() + done, text.size() - done, MSG_NOSIGNAL);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) return Error{SessionError::kOwnerGone, std::strerror(errno)};
    done += static_cast<std::size_t>(n);
  }
  return Ok{};
}

// One line from `fd` (without its newline) into `line`, `buf` keeping what follows. False at
// the end of the stream, on an error or past `max` bytes.
bool read_line(int fd, std::string& buf, std::string& line, std::size_t max) {
  for (;;) {
    const std::size_t nl = buf.find('\n');
    if (nl != std::string::npos) {
      line = buf.substr(0, nl);
      buf.erase(0, nl + 1);
      return true;
    }
    if (buf.size() > max) return false;
    char chunk[4096];
    const ssize_t n = ::recv(fd, chunk, sizeof chunk, 0);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) return false;
    buf.append(chunk, static_cast<std::size_t>(n));
  }
}

// The pid the lock file names (what the owner wrote there), or 0.
pid_t pid_in(int fd) {
  char text[32] = {};
  const ssize_t n = ::pread(fd, text, sizeof text - 1, 0);
  return n > 0 ? static_cast<pid_t>(std::atol(text)) : 0;
}

std::string status_line(const Status& s) {
  nlohmann::json j;
  if (s) {
    j = {{"ok", true}};
  } else {
    j = {{"ok", false}, {"code", s.error().code}, {"message", s.error().message}};
    if (s.error().detail) j["detail"] = *s.error().detail;
  }
  return j.dump() + "\n";
}

}  // namespace

fs::path owner_socket_path(const std::string& device) {
  return owner_dir() / (port_name(device) + ".sock");
}

fs::path owner_lock_path(const std::string& device) {
  return owner_dir() / (port_name(device) + ".lock");
}

std::optional<std::string> single_serial_device(const LinkOptions& links) {
  if (links.serial.size() > 1) return std::nullopt;
  std::string device;
  if (links.serial.size() == 1) {
    device = links.serial.front();
    const std::size_t eq = device.find('=');
    if (eq != std::string::npos) device = device.substr(eq + 1);
  } else if (const char* env = std::getenv("SCARATWIN_SERIAL"); env != nullptr) {
    device = env;
  }
  if (device.empty()) return std::nullopt;
  return device;
}

Result<std::unique_ptr<PortOwner>> PortOwner::claim(const std::string& device) {
  const fs::path dir = owner_dir();
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec) {
    return Error{SessionError::kOwnerSocket, fmt::format("cannot make {} for the port's owner: {}",
                                                         dir.string(), ec.message())};
  }
  ::chmod(dir.c_str(), 0700);
  std::unique_ptr<PortOwner> o(new PortOwner());
  o->socket_path_ = owner_socket_path(device);
  o->lock_path_ = owner_lock_path(device);
  o->lock_fd_ = ::open(o->lock_path_.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0600);
  if (o->lock_fd_ < 0) {
    return Error{SessionError::kOwnerSocket,
                 fmt::format("cannot open {}: {}", o->lock_path_.string(), std::strerror(errno))};
  }
  if (::flock(o->lock_fd_, LOCK_EX | LOCK_NB) != 0) {
    const pid_t pid = pid_in(o->lock_fd_);
    return Error{SessionError::kPortOwned,
                 fmt::format("the robot's port {} is owned by another scaratwin hub{}: the "
                             "statements go to it; stop that one first (Ctrl-C in its "
                             "terminal{})",
                             device, pid > 0 ? fmt::format(" (pid {})", pid) : std::string(),
                             pid > 0 ? fmt::format(", or kill {}", pid) : std::string())};
  }
  const std::string pid = fmt::format("{}\n", ::getpid());
  if (::ftruncate(o->lock_fd_, 0) != 0 ||
      ::pwrite(o->lock_fd_, pid.data(), pid.size(), 0) != static_cast<ssize_t>(pid.size())) {
    return Error{SessionError::kOwnerSocket,
                 fmt::format("cannot write {}: {}", o->lock_path_.string(), std::strerror(errno))};
  }
  // a socket left by an owner that was killed: the claim is ours now
  ::unlink(o->socket_path_.c_str());
  sockaddr_un addr{};
  addr.sun_family = AF_UNIX;
  const std::string path = o->socket_path_.string();
  if (path.size() >= sizeof addr.sun_path) {
    return Error{SessionError::kOwnerSocket,
                 fmt::format("the socket's path is too long: {}", path)};
  }
  std::memcpy(addr.sun_path, path.c_str(), path.size() + 1);
  o->listen_fd_ = ::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
  if (o->listen_fd_ < 0 ||
      ::bind(o->listen_fd_, reinterpret_cast<const sockaddr*>(&addr), sizeof addr) != 0 ||
      ::chmod(path.c_str(), 0600) != 0 || ::listen(o->listen_fd_, 16) != 0 ||
      ::pipe2(o->wake_, O_CLOEXEC) != 0) {
    return Error{SessionError::kOwnerSocket,
                 fmt::format("cannot listen on {}: {}", path, std::strerror(errno))};
  }
  return o;
}

void PortOwner::stop() {
  if (thread_.joinable()) {
    const char c = 0;
    (void)!::write(wake_[1], &c, 1);
    thread_.join();
  }
  std::unique_lock<std::mutex> lock(mu_);
  idle_.wait(lock, [this] { return active_ == 0; });
}

PortOwner::~PortOwner() {
  stop();
  if (listen_fd_ >= 0) {
    ::close(listen_fd_);
    ::unlink(socket_path_.c_str());
  }
  for (int fd : wake_) {
    if (fd >= 0) ::close(fd);
  }
  if (lock_fd_ >= 0) ::close(lock_fd_);  // the claim ends with the descriptor
}

void PortOwner::serve(Handler handler) {
  handler_ = std::move(handler);
  thread_ = std::thread([this] { accept_loop(); });
}

void PortOwner::accept_loop() {
  for (;;) {
    pollfd fds[2] = {{listen_fd_, POLLIN, 0}, {wake_[0], POLLIN, 0}};
    if (::poll(fds, 2, -1) < 0) {
      if (errno == EINTR) continue;
      return;
    }
    if (fds[1].revents != 0) return;
    const int fd = ::accept4(listen_fd_, nullptr, nullptr, SOCK_CLOEXEC);
    if (fd < 0) continue;
    {
      std::lock_guard<std::mutex> lock(mu_);
      ++active_;
    }
    std::thread([this, fd] {
      answer(fd);
      ::close(fd);
      // notified under the lock: once it is released this thread touches nothing of the
      // owner, which stop() may then destroy
      std::lock_guard<std::mutex> lock(mu_);
      if (--active_ == 0) idle_.notify_all();
    }).detach();
  }
}

void PortOwner::answer(int fd) {
  std::string buf, line;
  if (!read_line(fd, buf, line, kMaxRequestBytes)) return;
  OwnerRequest request;
  auto j = nlohmann::json::parse(line, nullptr, false);
  if (j.is_object()) {
    request.statement = j.value("statement", std::string());
    request.script = j.value("script", std::string());
    request.name = j.value("name", std::string());
  }
  if (!j.is_object() || request.statement.empty() == request.script.empty()) {
    (void)write_all(fd, status_line(Error{SessionError::kOwnerReply,
                                          "a request is {\"statement\":TEXT} or "
                                          "{\"script\":TEXT,\"name\":FILE}"}));
    return;
  }
  std::mutex mu;
  bool lost = false;
  const Say say = [&](const std::string& text) {
    std::lock_guard<std::mutex> lock(mu);
    if (!lost) lost = !write_all(fd, nlohmann::json{{"line", text}}.dump() + "\n").ok();
  };
  const auto gone = [&]() {
    {
      std::lock_guard<std::mutex> lock(mu);
      if (lost) return true;
    }
    // the client sends nothing after its request: readable means it closed its end
    pollfd p{fd, POLLIN | POLLRDHUP, 0};
    return ::poll(&p, 1, 0) > 0 && (p.revents & (POLLIN | POLLRDHUP | POLLHUP | POLLERR)) != 0;
  };
  const Status s = handler_(request, say, gone);
  std::lock_guard<std::mutex> lock(mu);
  (void)write_all(fd, status_line(s));
}

std::string statement_line(const Statement& statement, const std::string& result) {
  if (statement.line > 0) {
    return fmt::format("{:>4}  {:<36} {}", statement.line, statement.source, result);
  }
  return result;
}

Status run_request(Hub& hub, const OwnerRequest& request, const Say& say) {
  const StatementLog log = [&say](const Statement& st, const std::string& result) {
    say(statement_line(st, result));
  };
  if (!request.statement.empty()) {
    auto st = parse_statement(request.statement, 0);
    if (!st) return st.error();
    return execute(hub, *st, log);
  }
  auto script = parse_script(request.script, request.name);
  if (!script) return script.error();
  return run_script(hub, *script, request.name, log);
}

std::optional<Status> ask_owner(const std::string& device, const OwnerRequest& request,
                                const Say& say, pid_t* owner_pid) {
  const fs::path path = owner_socket_path(device);
  sockaddr_un addr{};
  addr.sun_family = AF_UNIX;
  const std::string p = path.string();
  if (p.size() >= sizeof addr.sun_path) return std::nullopt;
  std::memcpy(addr.sun_path, p.c_str(), p.size() + 1);
  const int fd = ::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
  if (fd < 0) return Status{Error{SessionError::kOwnerSocket, std::strerror(errno)}};
  if (::connect(fd, reinterpret_cast<const sockaddr*>(&addr), sizeof addr) != 0) {
    const int err = errno;
    ::close(fd);
    // no owner: no socket, or the one of an owner that was killed
    if (err == ENOENT || err == ECONNREFUSED) return std::nullopt;
    return Status{
        Error{SessionError::kOwnerSocket,
              fmt::format("cannot reach the port's owner at {}: {}", p, std::strerror(err))}};
  }
  pid_t pid = 0;
  ucred cred{};
  socklen_t len = sizeof cred;
  if (::getsockopt(fd, SOL_SOCKET, SO_PEERCRED, &cred, &len) == 0) pid = cred.pid;
  if (owner_pid != nullptr) *owner_pid = pid;
  nlohmann::json j = request.script.empty()
                         ? nlohmann::json{{"statement", request.statement}}
                         : nlohmann::json{{"script", request.script}, {"name", request.name}};
  if (Status s = write_all(fd, j.dump() + "\n"); !s) {
    ::close(fd);
    return Status{Error{SessionError::kOwnerGone,
                        fmt::format("the port's owner (pid {}) did not take the request: {}", pid,
                                    s.error().message)}};
  }
  std::string buf, line;
  while (read_line(fd, buf, line, kMaxRequestBytes)) {
    auto r = nlohmann::json::parse(line, nullptr, false);
    if (!r.is_object()) continue;
    if (r.contains("line") && r["line"].is_string()) {
      if (say) say(r["line"].get<std::string>());
      continue;
    }
    if (!r.contains("ok")) continue;
    ::close(fd);
    if (r.value("ok", false)) return Status{Ok{}};
    Error e{r.value("code", error_code(SessionError::kOwnerReply)),
            r.value("message", std::string("the port's owner refused without a reason"))};
    if (r.contains("detail") && r["detail"].is_number_integer()) e.detail = r["detail"].get<int>();
    return Status{e};
  }
  ::close(fd);
  return Status{Error{SessionError::kOwnerGone,
                      fmt::format("the port's owner (scaratwin hub, pid {}) ended the "
                                  "connection before it answered: did it stop? (its terminal "
                                  "says why)",
                                  pid)}};
}

}  // namespace scaratwin::session
