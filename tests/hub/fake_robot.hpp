// A fake robot for the hub's unit tests: the firmware's serial protocol (docs/protocol.md
// sections 5, 6, 8, 9, 11) on a real pseudo-terminal, played by one thread of the test process.
//
// The hub reaches the physical robot through a tty path; the emulator (`scaratwin-robot`) runs
// the real firmware on a simulated AVR behind a pty, paced to the wall clock, which makes a test
// slow and its timing the emulator's. This fake answers the same packets the same way (the
// replies, the ER codes, the events, the credits of a 15-point queue) with no physics: a
// trajectory point's counts are reached linearly over its dt, a homing or a jog lands at once
// (a homing after a short delay). The hub's SerialLink opens device_path() like any tty.
//
// Controls let a test cut the link (set_silent), see what the host sent in order
// (received_codes: a refusal must leave nothing moving) and read the state the robot is in.
#pragma once

#include <array>
#include <atomic>
#include <cstdint>
#include <deque>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <string_view>
#include <thread>
#include <vector>

#include "scaratwin/core/result.hpp"
#include "scaratwin/kinematics/robot_model.hpp"
#include "scaratwin/protocol/codec.hpp"
#include "scaratwin/protocol/messages.hpp"

namespace scaratwin::fake {

struct FakeRobotOptions {
  // The description hash the robot answers a described hello with; empty: description_hash()
  // of the model (another value makes the hub refuse the robot).
  std::string description_hash;
  std::string device_name = "fake";
  std::string software_version = "0.1.0";
  // Trajectory queue slots (the Uno's 15).
  int queue_slots = 15;
  // Periodic ST reports from the start (Hz). The firmware starts at its setting 3 (100 Hz); 0
  // here keeps a test's stream quiet until it sends SR.
  int initial_report_hz = 0;
  // How long HM takes (the moving flag is set meanwhile), seconds.
  double homing_s = 0.02;
  // The robot comes up homed at the home pose (a robot the hub finds already homed).
  bool start_homed = false;
};

class FakeRobot {
 public:
  // Opens a pty pair (raw) and starts the robot's thread. Fails (TransportError::kOpenFailed)
  // when no pty can be had.
  static Result<std::unique_ptr<FakeRobot>> start(const RobotModel& model,
                                                  FakeRobotOptions options = {});
  ~FakeRobot();  // stops the thread, closes both sides
  FakeRobot(const FakeRobot&) = delete;
  FakeRobot& operator=(const FakeRobot&) = delete;

  // The slave side's path (/dev/pts/N), for SerialOptions::device.
  std::string device_path() const { return slave_path_; }

  // Silent: nothing is sent any more (replies, reports and events are dropped, as on a cut
  // link; report numbers still advance, so the gap shows when it ends). What the host sends is
  // still acted on.
  void set_silent(bool silent);
  // What the host sent, in order of arrival: the two-letter codes, "!", "#", "~" for the
  // real-time bytes, "?" for a line that did not decode.
  std::vector<std::string> received_codes() const;
  // The state an ST would report now (seq: the last report's number).
  protocol::DeviceState state() const;
  // Motions started: homings, jogs and trajectories that began to run.
  int moves_started() const;
  // The step counts of the model's home pose (where HM leaves the robot).
  protocol::MotorSteps home_steps() const { return home_steps_; }

 private:
  // A trajectory point under way: the counts and wrist go linearly from `from` to `to`.
  struct Segment {
    std::int32_t seq = 0;
    std::int64_t t0_us = 0;
    std::int64_t t1_us = 0;
    protocol::MotorSteps from{};
    protocol::MotorSteps to{};
    std::int32_t wrist_from_cdeg = 0;
    std::int32_t wrist_to_cdeg = 0;
    std::optional<std::int32_t> grip_cdeg;
  };
  struct Point {
    std::int32_t seq = 0;
    std::int64_t dt_us = 0;
    protocol::MotorSteps steps{};
    std::int32_t wrist_cdeg = 0;
    std::optional<std::int32_t> grip_cdeg;
  };
  struct Trajectory {
    bool active = false;   // TB accepted, last point not reached (the ST flag 4)
    bool running = false;  // the queue was full or complete once: points execute
    std::int32_t n = 0;
    std::int32_t next_seq = 0;  // next TP expected
    std::int32_t done = 0;      // points reached
    bool underrun_sent = false;
    std::deque<Point> queue;  // points waiting (their slots are taken)
    std::optional<Segment> segment;
    // the firmware's planner state, for its speed and acceleration checks
    std::array<double, 3> plan_position{};
    std::array<double, 3> plan_velocity{};
  };

  FakeRobot(const RobotModel& model, FakeRobotOptions options);
  void run();
  std::int64_t now_us() const;

  // all below: mu_ held
  void on_bytes(std::string_view bytes, std::int64_t now);
  void handle(const protocol::SerialToDevice& message, std::int64_t now);
  void on_realtime(protocol::Realtime command, std::int64_t now);
  void on_hello(const protocol::Hello& hello);
  void on_trajectory_begin(const protocol::TrajectoryBegin& tb);
  void on_trajectory_point(const protocol::TrajectoryPoint& tp, std::int64_t now);
  void on_jog(const protocol::Jog& jog);
  void on_config(const protocol::Config& cf);
  void on_home(std::int64_t now);
  void stop_now(std::int64_t now);
  // True (and the ER sent) when a motion is refused: halted or held (14), busy (9). A
  // trajectory at rest whose host gave up is dropped instead (docs/protocol.md section 8).
  bool motion_refused();
  bool motors_running() const;
  void advance(std::int64_t now);
  void start_next_segment(std::int64_t start_us);
  void maybe_report(std::int64_t now);
  void send_report(std::int64_t now, bool periodic);
  protocol::DeviceState make_state(std::int64_t now) const;
  protocol::MotorSteps positions(std::int64_t now) const;
  std::int32_t wrist_cdeg(std::int64_t now) const;
  std::int32_t queue_free() const;
  std::uint32_t flags() const;
  void send(const protocol::SerialFromDevice& message, bool droppable = false);
  void ack(const char* code, std::optional<std::int32_t> value = std::nullopt);
  void error(std::int32_t code, std::optional<std::int32_t> detail = std::nullopt);
  void event(protocol::DeviceEventCode code, std::optional<std::int32_t> value = std::nullopt);
  void flush_output();
  std::int64_t next_deadline(std::int64_t now) const;

  const RobotModel model_;
  const FakeRobotOptions options_;
  const std::string hash_;
  protocol::MotorSteps home_steps_{};
  int master_ = -1;
  int slave_ = -1;
  int wake_ = -1;  // eventfd: the destructor wakes the thread
  std::string slave_path_;
  std::int64_t start_us_ = 0;
  std::atomic<bool> quit_{false};
  std::thread thread_;

  mutable std::mutex mu_;
  protocol::SerialToDeviceDecoder decoder_;
  std::string out_;  // bytes not yet written to the master
  bool silent_ = false;
  std::vector<std::string> received_;
  int moves_ = 0;
  // the robot
  protocol::MotorSteps steps_{};
  std::int32_t wrist_cdeg_ = 0;
  std::int32_t grip_cdeg_ = 0;
  bool homed_ = false;
  bool rehoming_ = false;
  bool halted_ = false;
  bool held_ = false;
  std::int64_t held_since_us_ = 0;
  std::optional<std::int64_t> homing_done_us_;
  Trajectory traj_;
  std::array<std::int32_t, 11> settings_{};  // CF keys 1..11
  // reports
  std::int32_t report_hz_ = 0;
  std::int64_t report_period_us_ = 0;
  std::int64_t next_report_us_ = 0;
  std::uint16_t report_seq_ = 0;  // number of the next report
  std::uint16_t last_seq_ = 0;
};

}  // namespace scaratwin::fake
