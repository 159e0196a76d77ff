// The hub: holds the physical robot (serial link to the firmware) and the virtual robot (TCP
// link to the simulator) together, as the paper's MATLAB data-processing layer did, and
// records everything in the twin database.
//
//  - Digital mirror: every state report (ST) of the robot is converted from step counts to
//    joints and forwarded to the simulator (JD); the simulator's JA reply closes the frame.
//    Each frame's device sequence number and timestamp, hub receive time and simulator apply
//    time are recorded, so latency and loss are measured per frame.
//  - Digital control: joint trajectories are loaded into the robot with credit-based flow
//    control (TB/TP) while the mirror shows the robot's actual motion in the simulator.
//  - Digital prediction: trajectories run first in the simulator (simulate mode, physics,
//    grasping), then are replayed on the robot; see hub/tasks.hpp.
//
// Thread safety: every public method may be called from any thread; the links' handlers run
// on the io thread. Times recorded in the database are seconds since the current run began.
#pragma once

#include <array>
#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <functional>
#include <initializer_list>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "scaratwin/core/result.hpp"
#include "scaratwin/hub/analysis.hpp"
#include "scaratwin/hub/robot_interface.hpp"
#include "scaratwin/hub/twin_db.hpp"
#include "scaratwin/kinematics/motor.hpp"
#include "scaratwin/kinematics/workcell.hpp"
#include "scaratwin/protocol/messages.hpp"
#include "scaratwin/trajectory/trajectory.hpp"
#include "scaratwin/transport/channel.hpp"
#include "scaratwin/transport/io_thread.hpp"
#include "scaratwin/transport/serial.hpp"
#include "scaratwin/transport/statements.hpp"
#include "scaratwin/transport/tcp.hpp"

namespace scaratwin {

struct HubOptions {
  // /dev/ttyACM0 or the emulator's pty: the robot of connect() without a RobotInterface
  std::string serial_device;
  unsigned baud = 115200;
  std::string sim_host = "127.0.0.1";
  std::uint16_t sim_port = 55016;
  std::string sim_token;  // the simulator's access token when it asks for one (security.md)
  // "observe": the hub only watches the simulator (the stop command, which may run while
  // another hub controls it); empty: it controls it (one controlling client at a time)
  std::string sim_role;
  // Names the robot in what the hub prints ("scaratwin: robot 'left': the simulator link is
  // back") where one process holds several hubs; empty: the messages name none.
  std::string log_name;
  // The robot's index in the simulator's workcell (protocol v2, docs/protocol.md section
  // 11.3): every robot-addressed packet to the simulator carries it; 0, the first robot, sends
  // the v1 bytes. A simulator without that robot refuses it (error 19, no_robot).
  int sim_robot = 0;
  // Where that robot's base stands in the simulator's world W (the workcell's pose of it;
  // identity for robot 0 and for the paper's robot). The simulator's object positions are in
  // W; the hub gives and takes them in the robot's base frame (spawn_cube(), objects()), the
  // frame of its description's scene (scene_in_base()).
  BasePose base;
  int report_rate_hz = 100;           // robot state reports while connected
  double hello_timeout_s = 5.0;       // a real board spends ~2 s in its bootloader
  double desync_threshold_m = 0.003;  // tool deviation that raises the desync alarm
  int desync_persist = 5;             // consecutive reports above it
  double min_point_dt_s = 0.02;       // trajectory points sent to the robot at most this dense
  double reply_timeout_s = 3.0;       // a request without reply is a lost link after this
  // No state report for this long (at least ten report periods) is said at once; when the
  // reports come back with the robot's clock as far on, the link was cut, and a trajectory
  // running is stopped (docs/protocol.md section 11.1). 0: not watched.
  double robot_silence_s = 0.15;
  // Where the hub's robot description came from (config/scara.toml), for the message that
  // refuses a robot or a simulator built for another description; may be empty.
  std::string description_source;
};

// The robot as its last state report showed it.
struct PhysicalState {
  protocol::DeviceState raw;
  JointVector q{};        // from the actual step counts
  double grip_deg = 0.0;  // gripper servo output
  std::int64_t rx_steady_us = 0;
  bool valid = false;
};

// What homing again found: the robot has no encoders, but each endstop closes where its
// motor really is, and the firmware reports how far the count was from it.
struct HomingCheck {
  bool measured = false;                       // the robot was homed before this homing
  std::array<std::int32_t, 3> offset_steps{};  // Z, J2, J3: count - true position (lost steps)
  double tool_m = 0.0;  // how far the tool really was from where its counts put it (home pose)
};

// Live mirror counters (also shown by the demo's progress line).
struct MirrorCounters {
  std::uint64_t frames = 0;           // JD frames forwarded
  std::uint64_t applied = 0;          // JA replies received
  std::uint64_t lost = 0;             // ST sequence gaps
  std::uint64_t not_applied = 0;      // frames forwarded whose JA never came (refused, link lost)
  std::uint64_t sim_link_losses = 0;  // times the simulator link went down since connect
  // robot's sample -> simulator applied (the robot's clock aligned online, as the report's
  // figure), last frame
  double last_latency_ms = 0.0;
  double mean_latency_ms = 0.0;
};

class Hub {
 public:
  // Connects both links, exchanges hellos and starts the robot's state reports. `db` may be
  // null (nothing recorded); it must outlive the twin. The robot is the serial device of
  // `options` (serial_robot()).
  static Result<std::unique_ptr<Hub>> connect(const RobotModel& model, const HubOptions& options,
                                              TwinDb* db);
  // The same with the robot given as a hardware interface (a serial board, the emulated
  // robot, a fake): configured here, held until the hub goes.
  static Result<std::unique_ptr<Hub>> connect(const RobotModel& model,
                                              std::unique_ptr<RobotInterface> robot,
                                              const HubOptions& options, TwinDb* db);
  ~Hub();
  Hub(const Hub&) = delete;
  Hub& operator=(const Hub&) = delete;

  const RobotModel& model() const { return model_; }
  // The physical robot's hardware interface (its kind, where it is).
  const RobotInterface& robot_interface() const { return *robot_if_; }
  // Replaces the description (a calibrated one after calibration): later conversions between
  // step counts and joints, plans and the mirror use it. Call it between statements.
  void set_model(const RobotModel& model);

  // --- runs: what is recorded goes to the current run; between end_run and the next
  // begin_run nothing is recorded (with a database; current_run() is then 0) --------------
  Result<std::int64_t> begin_run(const std::string& kind, const std::string& label,
                                 std::int64_t parent = 0, std::int64_t ref = 0);
  Status end_run(bool ok);
  std::int64_t current_run() const;
  double run_time_s() const;  // seconds since the current run began
  void record_event(const std::string& kind, const std::string& detail);
  void record_metric(const std::string& name, double value, const std::string& unit);

  // --- digital mirror ---------------------------------------------------------------------
  // Forward every state report to the simulator (JD) while on.
  void set_mirror(bool on);
  MirrorCounters mirror_counters() const;
  // The simulator link is up (it reconnects by itself after a loss).
  bool sim_connected() const { return sim_link_up(); }

  // --- physical robot ---------------------------------------------------------------------
  PhysicalState physical() const;
  // Waits for a state report newer than now.
  Result<PhysicalState> fresh_physical(double timeout_s);
  // A fresh state report to start a motion from. Refused while the robot is not homed (its
  // counts are then no joint angles: a board that reset, a power-up) with the firmware's own
  // code for it (protocol_error_code(7), `not homed`), before anything is planned or sent.
  Result<PhysicalState> motion_start(double timeout_s = 2.0);
  // Homes against the endstops; fails at once if the robot reports that homing failed. When
  // the robot was homed before, its switches measure the steps lost since (last_homing());
  // a tool offset beyond the desync threshold raises a desync alarm.
  Status home(double timeout_s = 120.0);
  HomingCheck last_homing() const;
  // The direction each stepper joint last moved, from the reports (homing resets it): which
  // side of its dead band each joint rests on.
  MotionDirections directions() const;
  // Waits until a state report shows the robot at rest (no jog, no trajectory).
  Status wait_idle(double timeout_s);
  // Prepares the robot for a new motion after whatever an earlier one left: a hold, a stop
  // (halted), a trajectory at rest whose host gave up (killed, interrupted, link cut). Stops
  // such a leftover for good and clears the halt ('!' then '~'); does nothing otherwise.
  Status recover();
  // Loads `trajectory` (its first sample must be the robot's current pose) with credit flow
  // control (the numberTran3 statement) and waits until the robot reports it done. Gripper
  // events become the points' gripper angles. Each state report is checked against the plan
  // for the desync alarm while it runs. Returns the number of points run. Whatever ends it
  // early (a refusal, no progress, a lost link, a timeout, interrupt()) stops the robot
  // before the error returns; the error says whether the robot confirmed the stop.
  Result<int> run_trajectory(const JointTrajectory& trajectory, double timeout_s = 0.0);
  Status set_gripper(bool closed);
  Status jog(protocol::Axis axis, double delta);
  // Writes one of the robot's settings (CF: key and value as docs/protocol.md lists them).
  Status set_setting(int key, int value);
  // The stop statement: stops the robot at once ('!': the queue dropped, the step pulses end
  // within 50 us) and waits until it confirms (EV 6). It is then halted: home() or the next
  // trajectory (recover()) clears that. Fails when no confirmation comes within `timeout_s`
  // (0: the reply timeout of HubOptions, the same rule as for any request: the link is cut,
  // or the robot is gone); a robot that hears nothing from its host stops
  // by itself when its queue of points runs out (15 points: 0.3 s to a few seconds).
  Status stop(double timeout_s = 0.0);
  // Ctrl-C: stops the robot and makes the statement in progress (and every later wait of
  // this hub: trajectories, homing, sleep()) fail at once with "interrupted". Safe from any
  // thread (not from a signal handler).
  void interrupt();
  bool interrupted() const { return interrupted_.load(); }
  // Ends the effect of interrupt(): later statements and waits work again (a session that goes
  // on after Ctrl-C, as an interactive Python one does). The robot stays stopped and halted
  // until the next home() or trajectory (recover()) clears that.
  void clear_interrupt() { interrupted_ = false; }
  // Waits `seconds`, or until interrupt().
  Status sleep(double seconds);
  // Desync alarms raised during trajectories since connect.
  int desync_alarms() const { return desync_alarms_.load(); }
  // Farthest the robot's reported tool was from the planned path during the last (or the
  // current) trajectory: what the desync alarm compares with its threshold.
  double off_plan_worst_m() const;

  // --- virtual robot ----------------------------------------------------------------------
  Status sim_mode(protocol::SimMode mode);
  // Tells the simulator (and so its browser UI) which of the twin's modes the hub is running;
  // `homing` while the robot is not homed (its joints are then no limit warnings).
  Status set_twin_phase(protocol::TwinPhase phase);
  // Puts the virtual robot at `q` at once (kinematically, through mirror mode) and leaves the
  // simulator in simulate mode.
  Status place_virtual(const JointVector& q);
  // Object positions in the robot's base frame (HubOptions::base).
  Result<int> spawn_cube(CubeColor color, double x_m, double y_m);
  Status reset_scene();
  Result<std::vector<protocol::ObjectPose>> objects();
  // How often the arms of the simulator's workcell have touched so far (AC, docs/protocol.md
  // section 11.3): the simulator's physics, not the robots'.
  Result<protocol::ArmContacts> arm_contacts();
  Result<std::string> shoot(int width_px = 0, int height_px = 0);
  Result<transport::GripOutcome> sim_grasp(bool close);
  Result<protocol::SimState> sim_state();
  // Runs `trajectory` in the simulator (simulate mode): streams joint targets at its pace
  // (`speed` times real time), grasps and releases at its events, and records the simulated
  // joints as virtual samples. The virtual robot is first put at the trajectory's start. Returns
  // when the last target is sent and the robot settled.
  Status simulate_trajectory(const JointTrajectory& trajectory, double speed = 1.0);

  // Link counters for reports and the progress line.
  transport::LinkCounters serial_counters() const;
  transport::LinkCounters sim_counters() const;

 private:
  // The end of home(): a calibrated robot homed off its home pose moves there (hub.cpp).
  Status settle_at_home();
  Hub(const RobotModel& model, const HubOptions& options, TwinDb* db);
  void on_robot_packet(protocol::SerialFromDevice&& msg, const transport::RxPacket& rx);
  void on_device_state(const protocol::DeviceState& st, const transport::RxPacket& rx);
  void forward_to_sim(const PhysicalState& ps);
  // The simulator link went down or came back (io thread): a loss during a trajectory stops
  // the robot and fails the trajectory; a return sends the hello (and the mirror mode) again.
  void on_sim_link(transport::LinkState state);
  // The simulator answered the hello on a new connection (io thread): the link is back.
  void on_sim_answered();
  // Prints "scaratwin: <text>" on stderr, naming the robot when options_.log_name is set.
  void say(const std::string& text) const;
  // The watchdog thread: notices the robot link going silent.
  void watch_robot_link();
  // The trajectory in progress must end (interrupted, or motion_abort_ says why). An abort
  // reason outlives its trajectory, for the error it returns, but ends no later wait: a
  // homing after a cut must not fail with the cut's reason. mu_ held.
  bool motion_aborted() const { return interrupted_ || (in_motion_ && !motion_abort_.empty()); }
  bool sim_link_up() const {
    std::lock_guard<std::mutex> lock(mu_);
    return sim_up_;
  }
  void add_sample(SampleSource source, double t_s, std::int64_t seq, const JointVector& q,
                  double grip_deg);
  Result<protocol::DeviceEvent> wait_event(protocol::DeviceEventCode code, double timeout_s,
                                           std::uint64_t after);
  // The first of `codes` after event number `after`.
  Result<protocol::DeviceEvent> wait_event(std::initializer_list<protocol::DeviceEventCode> codes,
                                           double timeout_s, std::uint64_t after);
  Status check(const char* what, Result<transport::RobotChannel::Reply> r);
  // Waits for a state report whose flags satisfy `done` (fails when interrupted).
  Status wait_flags(const std::function<bool(std::uint32_t)>& done, double timeout_s);
  // Waits for the robot's stop confirmation (EV 6) after event number `mark`.
  Status wait_stopped(std::uint64_t mark, double timeout_s);
  // Waits until no motor runs (a hold at rest counts as at rest).
  Status wait_motors_at_rest(double timeout_s);

  RobotModel model_;
  HubOptions options_;
  TwinDb* db_;
  std::shared_ptr<transport::IoThread> io_;
  std::unique_ptr<RobotInterface> robot_if_;  // the physical robot's hardware interface
  std::unique_ptr<transport::TcpClient> tcp_;
  transport::RobotChannel* robot_ = nullptr;  // robot_if_'s channel, once configured
  std::unique_ptr<transport::SimChannel> sim_;
  std::unique_ptr<transport::Twin> statements_;  // the paper's control statements

  mutable std::mutex mu_;  // guards everything below and db_ writes
  std::condition_variable cv_;
  PhysicalState physical_;
  std::uint64_t state_count_ = 0;
  std::deque<std::pair<std::uint64_t, protocol::DeviceEvent>> events_;  // (serial no., event)
  std::uint64_t event_count_ = 0;
  std::int64_t run_ = 0;
  std::int64_t run_start_us_ = 0;
  bool mirror_ = false;
  bool sim_grip_closed_ = false;
  MirrorCounters mirror_counters_;
  double latency_sum_ms_ = 0.0;
  std::optional<std::uint16_t> last_seq_;
  // progress along the trajectory being run, for the desync alarm
  std::optional<PlanTracker> tracker_;
  std::atomic<int> desync_alarms_{0};  // over every trajectory run
  std::atomic<bool> interrupted_{false};
  bool sim_up_ = true;            // the simulator link is connected (mu_)
  bool connected_ = false;        // connect() has returned the hub (mu_)
  bool in_motion_ = false;        // a trajectory is being run (mu_)
  std::string motion_abort_;      // why the trajectory in progress must end (mu_)
  std::uint64_t abort_mark_ = 0;  // event count when the link watcher sent its stop (mu_)
  DesyncMonitor desync_{0.0, 1};  // the current trajectory's, reset when it starts
  HomingCheck last_homing_;
  // the side of its dead band each joint rests on (a calibrated backlash), from the reports
  MotionDirections report_dir_{};
  JointVector report_joint_{};  // the last report's joints (the belts' play applied)
  bool play_reset_ = false;     // homing: start the play again from the homed sides
  // the twin's phase as last set (set_twin_phase); homing restores it when it ends
  std::atomic<protocol::TwinPhase> twin_phase_{protocol::TwinPhase::kNone};
  // the robot is homed, as far as the hub knows (its state at connect, a homing since, no
  // reset since): until it is, the simulator is told the robot homes whatever the phase
  std::atomic<bool> robot_homed_{false};
  // the robot's clock aligned to the hub's, for the sample time of each mirrored frame (mu_)
  SampleClock sample_clock_;
  // the robot link's watchdog (a cut is silence: the firmware reports periodically)
  double silence_limit_s_ = 0.0;  // 0 until the reports are on
  // how long a statement waits for the watcher's stop (0: the reply timeout; mu_)
  double abort_stop_wait_s_ = 0.0;
  std::int64_t last_robot_rx_us_ = 0;  // (mu_)
  std::uint32_t last_robot_t_us_ = 0;  // the robot's clock in its last report (mu_)
  bool robot_clock_known_ = false;     // last_robot_t_us_ holds a report's clock (mu_)
  // a silence whose first report showed the robot's clock one period on: said as a stall
  // once the next report confirms it (mu_)
  bool stall_pending_ = false;
  std::int64_t stall_gap_ms_ = 0;
  std::int64_t stall_robot_ms_ = 0;
  std::uint32_t anchor_t_us_ = 0;       // the last report before that silence: its clock
  std::int64_t anchor_rx_us_ = 0;       // and when it was received (mu_)
  std::int64_t last_report_rx_us_ = 0;  // when the last report was received (mu_)
  bool robot_silent_ = false;           // (mu_)
  bool silence_said_ = false;           // the silence was said on stderr (mu_)
  bool stop_owed_ = false;      // a stop sent into the silence, sent again when it ends (mu_)
  bool watchdog_quit_ = false;  // (mu_)
  std::thread watchdog_;
};

}  // namespace scaratwin
