// Child processes of `scaratwin demo` (the simulator and the emulated robot): started from the
// executables installed beside `scaratwin`, their output read line by line, stopped (SIGTERM,
// then SIGKILL) when the owner goes away, so a failed demo leaves no process behind.
#pragma once

#include <sys/types.h>

#include <chrono>
#include <filesystem>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "scaratwin/core/result.hpp"

namespace scaratwin {

// The path of an executable that sits beside the running one (e.g. "scaratwin-sim").
std::filesystem::path sibling_executable(const std::string& name);

class ChildProcess {
 public:
  // Starts `exe` with `args`; its stdout and stderr are read by a thread and kept (and echoed
  // to `log` when set, with a prefix).
  static Result<std::unique_ptr<ChildProcess>> start(const std::filesystem::path& exe,
                                                     const std::vector<std::string>& args,
                                                     const std::filesystem::path& log = {});
  ~ChildProcess();  // stop()
  ChildProcess(const ChildProcess&) = delete;
  ChildProcess& operator=(const ChildProcess&) = delete;

  // Waits until a line of its output contains `needle`; returns that line. Fails when the
  // process exits first or the timeout passes (the error quotes its last output).
  Result<std::string> wait_for_line(const std::string& needle, std::chrono::milliseconds timeout);

  bool running();
  // Waits up to `timeout` for the process to exit by itself, then stop()s it. Returns the exit
  // status (or -signal).
  int wait_exit(std::chrono::milliseconds timeout);
  // SIGTERM, wait up to `grace`, then SIGKILL. Returns the exit status (or -signal).
  int stop(std::chrono::milliseconds grace = std::chrono::milliseconds(2000));
  pid_t pid() const { return pid_; }
  std::string output_tail(size_t lines = 20);

 private:
  ChildProcess() = default;
  void reader();

  pid_t pid_ = -1;
  int out_fd_ = -1;
  int log_fd_ = -1;
  std::string name_;
  std::thread thread_;
  std::mutex mu_;
  std::vector<std::string> lines_;
  bool eof_ = false;
  int status_ = 0;
  bool reaped_ = false;
};

}  // namespace scaratwin
