// Child processes of `scaratwin demo` (the simulator and the emulated robot): started from the
// executables installed beside `scaratwin`, their output read line by line, stopped (SIGTERM,
// then SIGKILL) when the owner goes away, so a failed demo leaves no process behind.
//
// Our own programs say they are ready in a machine-readable way: started with a ready
// descriptor, the child is passed `--ready-fd 3` and writes one JSON object on one line there
// once it serves (its ports, its pty), then closes it (docs/architecture.md). Its text output
// is for people and logs only.
#pragma once

#include <sys/types.h>

#include <chrono>
#include <cstdint>
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
// `name` in `dir`, or beside the running executable when `dir` is empty (a program that is not
// installed beside ours, such as Python, says where they are).
std::filesystem::path program_path(const std::filesystem::path& dir, const std::string& name);

// The descriptor a child is given for its ready line.
inline constexpr int kReadyFd = 3;

// The child's side: writes `json` and a newline on descriptor `fd` (its --ready-fd) and closes
// it. Fails when the descriptor is not open for writing.
Status announce_ready(int fd, const std::string& json);

// The descriptor a child started with a ready descriptor also gets as its lifeline (`--parent-fd
// 4`): the read end of a pipe whose write end only the parent holds, so it reads the end of
// the stream once the parent is gone, however it died (kill -9 included).
inline constexpr int kParentFd = 4;

// The child's side of the lifeline: a thread that waits on `fd` and sends this process SIGTERM
// once it reads the end (its handler then ends the program as Ctrl-C would). No simulator or
// emulated robot outlives the program that started it.
void exit_with_parent_fd(int fd);

class ChildProcess {
 public:
  // Starts `exe` with `args`; its stdout and stderr are read by a thread and kept (and echoed
  // to `log` when set, with a prefix). With `ready_fd` (our programs) the child also gets a pipe
  // as descriptor 3 and `--ready-fd 3` after `args`: wait_ready() reads its ready line; and its
  // lifeline as descriptor 4 with `--parent-fd 4`: it ends when this process does.
  static Result<std::unique_ptr<ChildProcess>> start(const std::filesystem::path& exe,
                                                     const std::vector<std::string>& args,
                                                     const std::filesystem::path& log = {},
                                                     bool ready_fd = false);
  ~ChildProcess();  // stop()
  ChildProcess(const ChildProcess&) = delete;
  ChildProcess& operator=(const ChildProcess&) = delete;

  // Waits until a line of its output contains `needle`; returns that line. Fails when the
  // process exits first or the timeout passes (the error quotes its last output).
  Result<std::string> wait_for_line(const std::string& needle, std::chrono::milliseconds timeout);

  // The line the child wrote on its ready descriptor (without the newline). Fails when the
  // child was started without one, closes it without a line (it exited: the error quotes its
  // last output) or the timeout passes. Once read, the same line is returned again.
  Result<std::string> wait_ready(std::chrono::milliseconds timeout);

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
  int ready_fd_ = -1;
  int lifeline_fd_ = -1;  // the write end of the child's --parent-fd
  std::string ready_;     // the ready line once read
  std::string name_;
  std::thread thread_;
  std::mutex mu_;
  std::vector<std::string> lines_;
  bool eof_ = false;
  int status_ = 0;
  bool reaped_ = false;
};

// What scaratwin-sim says on its ready descriptor once it serves: its protocol port, and the
// addresses of its browser view, fleet page and companion dialect where it serves them.
// {"program":"scaratwin-sim","port":N,"ui_url":"http://HOST:PORT/","fleet_url":"...",
//  "companion_port":N}
struct SimulatorReady {
  std::uint16_t port = 0;
  std::string ui_url;     // empty: no browser view
  std::string fleet_url;  // empty: no fleet page
  std::uint16_t companion_port = 0;
};
Result<SimulatorReady> parse_simulator_ready(const std::string& line);

// What scaratwin-robot says on its ready descriptor once the firmware runs: its pty, the
// side channel's and the camera's ports on 127.0.0.1, its plant and whether its port resets
// the board when opened.
// {"program":"scaratwin-robot","pty":"/dev/pts/N","side_port":N,"camera_port":N,
//  "plant":"as-built","auto_reset":true}
struct EmulatorReady {
  std::string pty;
  std::uint16_t side_port = 0;
  std::uint16_t camera_port = 0;  // 0: no camera
  std::string plant;              // "as-built" or "ideal"
  bool auto_reset = false;
};
Result<EmulatorReady> parse_emulator_ready(const std::string& line);

// Our two programs started with a ready descriptor, once they are ready (within `timeout`;
// an error quotes the program's last output).
struct StartedSimulator {
  std::unique_ptr<ChildProcess> process;
  SimulatorReady ready;
};
Result<StartedSimulator> start_simulator(const std::filesystem::path& exe,
                                         const std::vector<std::string>& args,
                                         const std::filesystem::path& log,
                                         std::chrono::milliseconds timeout);
struct StartedEmulator {
  std::unique_ptr<ChildProcess> process;
  EmulatorReady ready;
};
Result<StartedEmulator> start_emulator(const std::filesystem::path& exe,
                                       const std::vector<std::string>& args,
                                       const std::filesystem::path& log,
                                       std::chrono::milliseconds timeout);

}  // namespace scaratwin
