#include "scaratwin/hub/process.hpp"

#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

#include <fmt/format.h>

extern char** environ;

namespace scaratwin {

std::filesystem::path sibling_executable(const std::string& name) {
  std::error_code ec;
  const auto self = std::filesystem::read_symlink("/proc/self/exe", ec);
  return ec ? std::filesystem::path(name) : self.parent_path() / name;
}

Result<std::unique_ptr<ChildProcess>> ChildProcess::start(const std::filesystem::path& exe,
                                                          const std::vector<std::string>& args,
                                                          const std::filesystem::path& log) {
  if (access(exe.c_str(), X_OK) != 0) {
    return Error{HubError::kStartFailed, fmt::format("cannot run '{}': {} (is the build complete?)",
                                                     exe.string(), std::strerror(errno))};
  }
  int fds[2];
  if (pipe2(fds, O_CLOEXEC) != 0)
    return Error{HubError::kStartFailed, fmt::format("pipe: {}", std::strerror(errno))};
  posix_spawn_file_actions_t fa;
  posix_spawn_file_actions_init(&fa);
  posix_spawn_file_actions_adddup2(&fa, fds[1], STDOUT_FILENO);
  posix_spawn_file_actions_adddup2(&fa, fds[1], STDERR_FILENO);
  posix_spawn_file_actions_addopen(&fa, STDIN_FILENO, "/dev/null", O_RDONLY, 0);
  std::vector<std::string> all{exe.string()};
  all.insert(all.end(), args.begin(), args.end());
  std::vector<char*> argv;
  for (std::string& a : all) argv.push_back(a.data());
  argv.push_back(nullptr);
  pid_t pid = -1;
  const int rc = posix_spawn(&pid, exe.c_str(), &fa, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&fa);
  close(fds[1]);
  if (rc != 0) {
    close(fds[0]);
    return Error{HubError::kStartFailed,
                 fmt::format("cannot start '{}': {}", exe.string(), std::strerror(rc))};
  }
  std::unique_ptr<ChildProcess> p(new ChildProcess());
  p->pid_ = pid;
  p->out_fd_ = fds[0];
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
  out_fd_ = log_fd_ = -1;
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

ChildProcess::~ChildProcess() { stop(); }

}  // namespace scaratwin
