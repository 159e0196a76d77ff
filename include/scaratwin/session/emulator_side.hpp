// The emulated robot's side channel as the demo uses it (docs/firmware.md): the operator at
// the robot (jog buttons, placing the physical cubes) and the measuring instruments (the
// truth: the true joints, tool, cubes and lost steps). The twin's own logic never reads the
// truth; the demo reads it only to measure the twin and write its report.
#pragma once

#include <array>
#include <atomic>
#include <cstdint>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "scaratwin/core/result.hpp"
#include "scaratwin/kinematics/robot_model.hpp"
#include "scaratwin/protocol/messages.hpp"

namespace scaratwin::session {

// One truth line (TR) of the emulator.
struct TruthSample {
  std::uint64_t mono_us = 0;        // CLOCK_MONOTONIC of this machine when it was taken
  std::uint64_t sim_us = 0;         // emulated time since the emulator started
  std::uint64_t board_us = 0;       // emulated time since the board's last reset: its micros()
  bool as_built = false;            // plant=as-built (else ideal: no true joints or tool)
  JointVector q{};                  // true joints
  std::array<double, 4> tool{};     // true tool x, y, z (m), yaw (rad)
  std::array<long long, 3> lost{};  // steps lost by Z, J2, J3
  int held = -1;
};
// Parses one "TR ..." line; nullopt when it is not one.
std::optional<TruthSample> parse_truth_line(const std::string& line);

// A command connection (replies only).
class EmulatorSide {
 public:
  static Result<EmulatorSide> connect(std::uint16_t port);
  EmulatorSide(EmulatorSide&& o) noexcept;
  EmulatorSide& operator=(EmulatorSide&&) = delete;
  ~EmulatorSide();

  // Holds `button` ("j2+", "z-", ...) for `ms` of the robot's time.
  Status press(const std::string& button, int ms);
  // The operator puts a cube on the physical table / takes them all away.
  Status place(CubeColor color, double x_m, double y_m);
  Status clear();
  // The operator lays the printed calibration pattern on the table / takes it away.
  Status pattern(bool on);
  // The physical cubes (truth).
  Result<std::vector<protocol::ObjectPose>> cubes();
  Result<TruthSample> query();

 private:
  EmulatorSide() = default;
  Result<std::string> command(const std::string& line);
  int fd_ = -1;
};

// Records the truth at `hz` on its own connection, in its own thread, until destroyed.
class TruthRecorder {
 public:
  // The demos' rate: the firmware's state reports come at 100 Hz, so every report has a truth
  // sample within 2.5 ms of it.
  static constexpr double kDemoHz = 200.0;
  static Result<std::unique_ptr<TruthRecorder>> start(std::uint16_t port, double hz);
  ~TruthRecorder();
  // Samples taken between two CLOCK_MONOTONIC times (us).
  std::vector<TruthSample> between(std::uint64_t from_us, std::uint64_t to_us) const;

 private:
  TruthRecorder() = default;
  int fd_ = -1;
  std::atomic<bool> stop_{false};
  mutable std::mutex mutex_;
  std::vector<TruthSample> samples_;
  std::thread thread_;
};

std::uint64_t monotonic_us();

}  // namespace scaratwin::session
