// The hub's hardware interface to one physical robot, in the shape of ros2_control's
// SystemInterface: configure() makes the link; then the robot's state is read from its state
// reports and events (the channel's unsolicited packets) and commands are written as
// requests and realtime bytes on the channel (docs/protocol.md section 8). The hub holds
// robots only through it, so one hub code drives every kind of robot:
//
//  - serial_robot(): a board on a serial port, or any tty given by path;
//  - emulated_robot(): our firmware in the AVR emulator (scaratwin-robot), started for the
//    hub and stopped with it;
//  - the fake of the hub's unit tests (tests/hub/fake_robot.hpp): the firmware's protocol
//    played by a thread on a real pty, fast and controllable.
#pragma once

#include <chrono>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "scaratwin/core/result.hpp"
#include "scaratwin/transport/channel.hpp"
#include "scaratwin/transport/io_thread.hpp"

namespace scaratwin {

class RobotInterface {
 public:
  virtual ~RobotInterface() = default;

  // "serial", "emulated" or "fake".
  virtual const char* kind() const = 0;
  // Where the robot is, for messages: its device path ("/dev/ttyACM0", the emulator's pty).
  virtual std::string where() const = 0;
  // Opens the link on `io` and waits up to `timeout` until it is up (a board resets when
  // its port opens; the hub's hello then waits for its bootloader). Once per interface.
  virtual Status configure(const std::shared_ptr<transport::IoThread>& io,
                           std::chrono::milliseconds timeout) = 0;
  // The configured link's packet channel: requests and realtime bytes out (write), state
  // reports and events in through its unsolicited handler (read). configure() first.
  virtual transport::RobotChannel& channel() = 0;
  // The link's byte and packet counters (zero before configure()).
  virtual transport::LinkCounters counters() const = 0;
  // Closes the channel, then the link (and stops what the interface started). Idempotent;
  // the destructor does it.
  virtual void shutdown() = 0;
  // The emulated robot's side channel on 127.0.0.1 (docs/emulator.md: the truth of the robot
  // as built, faults), configure() first; 0 for a robot without one (a real board). It is a
  // measuring instrument for reports and tests: the hub never reads it.
  virtual std::uint16_t side_channel_port() const { return 0; }
};

// A robot on a serial device (a board's /dev/ttyACM0, or a pty given by path).
std::unique_ptr<RobotInterface> serial_robot(std::string device, unsigned baud = 115200);

struct EmulatedRobotOptions {
  // empty: scaratwin-robot beside the running program (sibling_executable)
  std::filesystem::path executable;
  std::vector<std::string> args;  // e.g. {"--speed", "2", "--plant", "ideal"}
  std::filesystem::path log;      // the emulator's output (empty: kept in memory only)
  unsigned baud = 115200;
};

// Our firmware in the AVR emulator: configure() starts the emulator, waits for the pty it
// prints ("pty: PATH") and opens it; shutdown() closes the link and stops the emulator.
std::unique_ptr<RobotInterface> emulated_robot(EmulatedRobotOptions options);

}  // namespace scaratwin
