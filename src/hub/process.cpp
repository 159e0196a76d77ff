#include "scaratwin/hub/process.hpp"

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <thread>

#include <fmt/format.h>

#include <nlohmann/json.hpp>

extern char** environ;

namespace scaratwin {

std::filesystem::path sibling_executable(const std::string& name) {
  std::error_code ec;
  const auto self = std::filesystem::read_symlink("/proc/self/exe", ec);
  return ec ? std::filesystem::path(name) : self.parent_path() / name;
}

Status announce_ready(int fd, const std::string& json) {
  const std::string line = json + "\n";
  std::size_t done = 0;
  while (done < line.size()) {
    const ssize_t n = ::write(fd, line.data() + done, line.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      const int err = errno;
      ::close(fd);
      return Error{
          HubError::kStartFailed,
          fmt::format("--ready-fd {}: cannot write the ready line: {}", fd, std::strerror(err))};
    }
    done += static_cast<std::size_t>(n);
  }
  ::close(fd);
  return Ok{};
}

void exit_with_parent_fd(int fd) {
  std::thread([fd] {
    char c;
    for (;;) {
      const ssize_t n = ::read(fd, &c, 1);
      if (n < 0 && errno == EINTR) continue;
      if (n > 0) continue;  // nobody writes; should anyone, it is no end
      break;
    }
    ::kill(::getpid(), SIGTERM);
  }).detach();
}

namespace {

// A pipe whose ends are above the standard descriptors and the ready descriptor (so that a
// dup2 onto 3 always copies, and clears FD_CLOEXEC on the copy).
bool high_pipe(int fds[2]) {
  int raw[2];
  if (pipe2(raw, O_CLOEXEC) != 0) return false;
  for (int i = 0; i < 2; ++i) {
    fds[i] = fcntl(raw[i], F_DUPFD_CLOEXEC, 10);
    close(raw[i]);
  }
  if (fds[0] < 0 || fds[1] < 0) {
    if (fds[0] >= 0) close(fds[0]);
    if (fds[1] >= 0) close(fds[1]);
    return false;
  }
  return true;
}

}  // namespace

Result<std::unique_ptr<ChildProcess>> ChildProcess::start(const std::filesystem::path& exe,
                                                          const std::vector<std::string>& args,
                                                          const std::filesystem::path& log,
                                                          bool ready_fd) {
  if (access(exe.c_str(), X_OK) != 0) {
    return Error{HubError::kStartFailed, fmt::format("cannot run '{}': {} (is the build complete?)",
                                                     exe.string(), std::strerror(errno))};
  }
  int fds[2];
  if (!high_pipe(fds))
    return Error{HubError::kStartFailed, fmt::format("pipe: {}", std::strerror(errno))};
  int ready[2] = {-1, -1};
  int lifeline[2] = {-1, -1};
  if (ready_fd && (!high_pipe(ready) || !high_pipe(lifeline))) {
    const int err = errno;
    for (int fd : {fds[0], fds[1], ready[0], ready[1]}) {
      if (fd >= 0) close(fd);
    }
    return Error{HubError::kStartFailed, fmt::format("pipe: {}", std::strerror(err))};
  }
  posix_spawn_file_actions_t fa;
  posix_spawn_file_actions_init(&fa);
  posix_spawn_file_actions_adddup2(&fa, fds[1], STDOUT_FILENO);
  posix_spawn_file_actions_adddup2(&fa, fds[1], STDERR_FILENO);
  posix_spawn_file_actions_addopen(&fa, STDIN_FILENO, "/dev/null", O_RDONLY, 0);
  if (ready_fd) {
    posix_spawn_file_actions_adddup2(&fa, ready[1], kReadyFd);
    posix_spawn_file_actions_adddup2(&fa, lifeline[0], kParentFd);
  }
  std::vector<std::string> all{exe.string()};
  all.insert(all.end(), args.begin(), args.end());
  if (ready_fd) {
    all.insert(all.end(),
               {"--ready-fd", std::to_string(kReadyFd), "--parent-fd", std::to_string(kParentFd)});
  }
  std::vector<char*> argv;
  for (std::string& a : all) argv.push_back(a.data());
  argv.push_back(nullptr);
  pid_t pid = -1;
  const int rc = posix_spawn(&pid, exe.c_str(), &fa, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&fa);
  close(fds[1]);
  if (ready_fd) {
    close(ready[1]);
    close(lifeline[0]);
  }
  if (rc != 0) {
    close(fds[0]);
    if (ready_fd) {
      close(ready[0]);
      close(lifeline[1]);
    }
    return Error{HubError::kStartFailed,
                 fmt::format("cannot start '{}': {}", exe.string(), std::strerror(rc))};
  }
  std::unique_ptr<ChildProcess> p(new ChildProcess());
  p->pid_ = pid;
  p->out_fd_ = fds[0];
  p->ready_fd_ = ready[0];
  p->lifeline_fd_ = lifeline[1];
  p->name_ = exe.filename().string();
  if (!log.empty()) {
    p->log_fd_ = ::open(log.c_str(), O_WRONLY | O_CREAT | O_APPEND | O_CLOEXEC, 0644);
  }
  p->thread_ = std::thread([raw = p.get()] { raw->reader(); });
  return p;
}

void ChildProcess::reader() {
  std::string partial;
  char buf[4096];
  for (;;) {
    const ssize_t n = read(out_fd_, buf, sizeof buf);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) break;
    if (log_fd_ >= 0) (void)!write(log_fd_, buf, static_cast<size_t>(n));
    partial.append(buf, static_cast<size_t>(n));
    size_t pos;
    while ((pos = partial.find('\n')) != std::string::npos) {
      std::lock_guard<std::mutex> lock(mu_);
      lines_.push_back(partial.substr(0, pos));
      partial.erase(0, pos + 1);
    }
  }
  std::lock_guard<std::mutex> lock(mu_);
  if (!partial.empty()) lines_.push_back(partial);
  eof_ = true;
}

Result<std::string> ChildProcess::wait_for_line(const std::string& needle,
                                                std::chrono::milliseconds timeout) {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  size_t seen = 0;
  for (;;) {
    {
      std::lock_guard<std::mutex> lock(mu_);
      for (; seen < lines_.size(); ++seen) {
        if (lines_[seen].find(needle) != std::string::npos) return lines_[seen];
      }
      if (eof_) break;
    }
    if (std::chrono::steady_clock::now() > deadline) {
      return Error{HubError::kNotReady,
                   fmt::format("{} did not print '{}' within {} ms; its last output:\n{}", name_,
                               needle, timeout.count(), output_tail())};
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  return Error{HubError::kExited,
               fmt::format("{} exited before printing '{}'; its last output:\n{}", name_, needle,
                           output_tail())};
}

Result<std::string> ChildProcess::wait_ready(std::chrono::milliseconds timeout) {
  if (!ready_.empty()) return ready_;
  if (ready_fd_ < 0) {
    return Error{HubError::kNotReady,
                 fmt::format("{} was started without a ready descriptor", name_)};
  }
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  std::string line;
  for (;;) {
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(
        deadline - std::chrono::steady_clock::now());
    pollfd p{ready_fd_, POLLIN, 0};
    const int r = left.count() > 0 ? ::poll(&p, 1, static_cast<int>(left.count())) : 0;
    if (r < 0 && errno == EINTR) continue;
    if (r == 0) {
      return Error{HubError::kNotReady,
                   fmt::format("{} was not ready within {} ms; its last output:\n{}", name_,
                               timeout.count(), output_tail())};
    }
    char buf[512];
    const ssize_t n = ::read(ready_fd_, buf, sizeof buf);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      // closed without a line: it exited (or failed) before it was ready; its last words
      // follow on its output
      (void)wait_exit(std::chrono::milliseconds(2000));
      return Error{
          HubError::kExited,
          fmt::format("{} exited before it was ready; its last output:\n{}", name_, output_tail())};
    }
    line.append(buf, static_cast<std::size_t>(n));
    if (const auto nl = line.find('\n'); nl != std::string::npos) {
      ready_ = line.substr(0, nl);
      ::close(ready_fd_);
      ready_fd_ = -1;
      return ready_;
    }
  }
}

bool ChildProcess::running() {
  if (reaped_) return false;
  int st = 0;
  if (waitpid(pid_, &st, WNOHANG) == pid_) {
    reaped_ = true;
    status_ = WIFEXITED(st) ? WEXITSTATUS(st) : -WTERMSIG(st);
    return false;
  }
  return true;
}

int ChildProcess::wait_exit(std::chrono::milliseconds timeout) {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  while (running() && std::chrono::steady_clock::now() < deadline) {
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  return stop();
}

int ChildProcess::stop(std::chrono::milliseconds grace) {
  if (running()) {
    kill(pid_, SIGTERM);
    const auto deadline = std::chrono::steady_clock::now() + grace;
    while (running() && std::chrono::steady_clock::now() < deadline) {
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    if (running()) {
      kill(pid_, SIGKILL);
      int st = 0;
      waitpid(pid_, &st, 0);
      reaped_ = true;
      status_ = -SIGKILL;
    }
  }
  if (thread_.joinable()) thread_.join();
  if (out_fd_ >= 0) close(out_fd_);
  if (log_fd_ >= 0) close(log_fd_);
  if (ready_fd_ >= 0) close(ready_fd_);
  out_fd_ = log_fd_ = ready_fd_ = -1;
  return status_;
}

std::string ChildProcess::output_tail(size_t n) {
  std::lock_guard<std::mutex> lock(mu_);
  std::string out;
  for (size_t i = lines_.size() > n ? lines_.size() - n : 0; i < lines_.size(); ++i) {
    out += "  " + lines_[i] + "\n";
  }
  return out;
}

ChildProcess::~ChildProcess() {
  stop();
  if (lifeline_fd_ >= 0) close(lifeline_fd_);
}

namespace {

// The JSON object of a ready line written by `program`.
Result<nlohmann::json> ready_object(const std::string& line, const char* program) {
  nlohmann::json j = nlohmann::json::parse(line, nullptr, false);
  if (j.is_discarded() || !j.is_object()) {
    return Error{HubError::kNotReady,
                 fmt::format("{}: its ready line is not a JSON object: '{}'", program, line)};
  }
  if (j.value("program", std::string()) != program) {
    return Error{HubError::kNotReady,
                 fmt::format("{}: the ready line is another program's: '{}'", program, line)};
  }
  return j;
}

Result<std::uint16_t> port_field(const nlohmann::json& j, const char* key, bool required,
                                 const char* program) {
  if (!j.contains(key)) {
    if (!required) return std::uint16_t{0};
  } else if (j[key].is_number_unsigned() && j[key].get<unsigned>() <= 65535) {
    return static_cast<std::uint16_t>(j[key].get<unsigned>());
  }
  return Error{
      HubError::kNotReady,
      fmt::format("{}: its ready line has no port '{}' (0..65535): {}", program, key, j.dump())};
}

}  // namespace

Result<SimulatorReady> parse_simulator_ready(const std::string& line) {
  constexpr const char* kProgram = "scaratwin-sim";
  auto j = ready_object(line, kProgram);
  if (!j) return j.error();
  SimulatorReady r;
  auto port = port_field(*j, "port", true, kProgram);
  if (!port) return port.error();
  r.port = *port;
  auto companion = port_field(*j, "companion_port", false, kProgram);
  if (!companion) return companion.error();
  r.companion_port = *companion;
  r.ui_url = j->value("ui_url", std::string());
  r.fleet_url = j->value("fleet_url", std::string());
  return r;
}

namespace {

// Starts `exe` with a ready descriptor and reads its ready line with `parse`.
template <typename Ready, typename Parse>
Result<std::pair<std::unique_ptr<ChildProcess>, Ready>> start_ready(
    const std::filesystem::path& exe, const std::vector<std::string>& args,
    const std::filesystem::path& log, std::chrono::milliseconds timeout, Parse parse) {
  auto p = ChildProcess::start(exe, args, log, true);
  if (!p) return p.error();
  auto line = (*p)->wait_ready(timeout);
  if (!line) return line.error();
  Result<Ready> ready = parse(*line);
  if (!ready) return ready.error();
  return std::pair{std::move(*p), std::move(*ready)};
}

}  // namespace

std::filesystem::path program_path(const std::filesystem::path& dir, const std::string& name) {
  return dir.empty() ? sibling_executable(name) : dir / name;
}

Result<StartedSimulator> start_simulator(const std::filesystem::path& exe,
                                         const std::vector<std::string>& args,
                                         const std::filesystem::path& log,
                                         std::chrono::milliseconds timeout) {
  auto s = start_ready<SimulatorReady>(exe, args, log, timeout, parse_simulator_ready);
  if (!s) return s.error();
  return StartedSimulator{std::move(s->first), std::move(s->second)};
}

Result<StartedEmulator> start_emulator(const std::filesystem::path& exe,
                                       const std::vector<std::string>& args,
                                       const std::filesystem::path& log,
                                       std::chrono::milliseconds timeout) {
  auto s = start_ready<EmulatorReady>(exe, args, log, timeout, parse_emulator_ready);
  if (!s) return s.error();
  return StartedEmulator{std::move(s->first), std::move(s->second)};
}

Result<EmulatorReady> parse_emulator_ready(const std::string& line) {
  constexpr const char* kProgram = "scaratwin-robot";
  auto j = ready_object(line, kProgram);
  if (!j) return j.error();
  EmulatorReady r;
  if (!(*j)["pty"].is_string() || (*j)["pty"].get<std::string>().empty()) {
    return Error{HubError::kNotReady,
                 fmt::format("{}: its ready line has no pty: {}", kProgram, j->dump())};
  }
  r.pty = (*j)["pty"].get<std::string>();
  auto side = port_field(*j, "side_port", true, kProgram);
  if (!side) return side.error();
  r.side_port = *side;
  auto camera = port_field(*j, "camera_port", false, kProgram);
  if (!camera) return camera.error();
  r.camera_port = *camera;
  r.plant = j->value("plant", std::string());
  r.auto_reset = j->value("auto_reset", false);
  return r;
}

}  // namespace scaratwin
