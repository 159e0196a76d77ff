// Twin figures from recorded data: mirror latency statistics, the deviation between two runs
// of the same plan (prediction vs physical replay, virtual vs physical), and the desync alarm.
// Pure: no I/O, no clock.
#pragma once

#include <array>
#include <cstdint>
#include <deque>
#include <utility>
#include <vector>

#include "scaratwin/hub/twin_db.hpp"
#include "scaratwin/kinematics/kinematics.hpp"
#include "scaratwin/kinematics/motor.hpp"
#include "scaratwin/trajectory/trajectory.hpp"

namespace scaratwin {

// Summary of a set of values (e.g. latencies in ms).
struct Stats {
  size_t count = 0;
  double mean = 0.0;
  double p50 = 0.0;
  double p95 = 0.0;
  double p99 = 0.0;
  double max = 0.0;
};
Stats summarize(std::vector<double> values);

// Mirror latency of each frame, in ms: the simulator's apply time minus the hub's receive
// time (hub_to_sim), and the device's sample time to the apply time (device_to_sim). The
// device clock is aligned to the host's by the smallest receive-minus-sample offset among the
// 50 frames on either side (the clocks drift), plus the wire time of one state report
// (`wire_s`), which no frame can beat.
struct LatencyFigures {
  Stats hub_to_sim_ms;
  Stats device_to_sim_ms;
  std::vector<double> device_to_sim_series_ms;
  int64_t lost_frames = 0;  // sequence gaps (seq wraps at 65536)
};
LatencyFigures latency_figures(const std::vector<LatencyRecord>& frames, double wire_s);

// The wire time of one state report at `baud`: about 55 bytes with the line end, 10 bits a
// byte (the `wire_s` every latency figure takes).
constexpr double state_report_wire_s(double baud) { return 55.0 * 10.0 / baud; }

// The robot's sample clock on the host's, online, as latency_figures aligns it offline: the
// sample time of a report is its device time plus the smallest receive-minus-sample offset of
// the last `window` reports (the robot's clock unwrapped; the offline form takes the frames on
// either side), minus the wire time of one report (`wire_s`), which no report can beat. A robot
// clock that goes back or jumps a minute (a restart) starts the window again.
class SampleClock {
 public:
  explicit SampleClock(std::size_t window = 100, double wire_s = 0.0);
  // the host time (the receive clock's) at which the robot sampled a report stamped
  // `device_t_us` (u32, wraps) and received at `rx_us`
  int64_t sample_time_us(uint32_t device_t_us, int64_t rx_us);
  void reset();

 private:
  std::size_t window_;
  int64_t wire_us_;
  bool started_ = false;
  uint32_t last_dev_ = 0;
  int64_t dev_ = 0;                                // unwrapped
  uint64_t n_ = 0;                                 // reports seen since the window started
  std::deque<std::pair<uint64_t, int64_t>> mins_;  // (report, offset), offsets increasing
};

// Deviation of run B from run A, B resampled at A's times (linear interpolation).
struct Deviation {
  std::array<double, kNumJoints> joint_rms{};  // m for d1, rad for the others
  std::array<double, kNumJoints> joint_max{};
  double tool_rms_m = 0.0;
  double tool_max_m = 0.0;
  double tool_final_m = 0.0;
  std::vector<double> t_s;         // A's times inside B's span
  std::vector<double> tool_err_m;  // tool deviation at those times
};
Deviation compare_runs(const RobotModel& model, const std::vector<JointRecord>& a,
                       const std::vector<JointRecord>& b, double b_time_offset_s = 0.0);

// Where along a plan a joint state lies: the plan time of the nearest point of the plan's
// polyline (joints linear between samples; d1 in m, J2 and J3 weighted 0.1 m/rad, the wrist
// not at all as it does not move the tool) among plan times [from_s, to_s], and the tool
// distance from the state to that point. With
// `skip_cost` > 0 a later point must be nearer by that fraction of the path length between
// the point at from_s and it: of two equally near points (a path that comes back the way it
// went) the earlier wins, and a pause in the plan costs nothing to skip.
struct PlanPoint {
  double t_s = 0.0;
  double tool_distance_m = 0.0;
};
PlanPoint nearest_on_plan(const RobotModel& model, const JointTrajectory& plan,
                          const JointVector& q, double from_s, double to_s, double skip_cost = 0.0);

// Plan time reached by each sample of a run of `plan` ("progress"): the nearest point of the
// plan, searched forward only (a run never goes back along its plan), at most `window_s` of
// plan time ahead of the previous sample's progress, the path skipped costing 10 % of its length.
std::vector<double> plan_progress(const RobotModel& model, const JointTrajectory& plan,
                                  const std::vector<JointRecord>& run, double window_s = 2.0);

// plan_progress one joint state at a time, for a run in progress: follow() returns the
// state's progress along the plan and its tool distance from the plan there. Knows no clock:
// a robot that starts late, holds on an empty queue or runs on a slower clock stays on its
// path; only leaving the path counts.
class PlanTracker {
 public:
  explicit PlanTracker(const JointTrajectory& plan, double window_s = 2.0);
  PlanPoint follow(const RobotModel& model, const JointVector& q);
  double progress_s() const { return at_; }

 private:
  const JointTrajectory* plan_;
  double window_s_;
  double at_;
};

// Deviation of run B from run A where both ran `plan`, compared at equal progress along the
// plan instead of at equal time: a later start, a pause or a clock running at another rate
// does not count, only where the two robots went. Deviation::t_s holds A's times.
Deviation compare_runs_by_progress(const RobotModel& model, const JointTrajectory& plan,
                                   const std::vector<JointRecord>& a,
                                   const std::vector<JointRecord>& b);

// A recorded run as a plan (its samples, in time order), so that another run of the same plan
// can be compared with it by progress: the replay against the prediction.
JointTrajectory as_plan(const std::vector<JointRecord>& run);

// Joint state of a recorded series at time t (linear interpolation, clamped).
JointVector interpolate(const std::vector<JointRecord>& series, double t_s);

// Desync alarm: raised when the tool deviation between the expected and the observed pose
// stays above `threshold_m` for `persist` consecutive checks; once per such streak.
class DesyncMonitor {
 public:
  DesyncMonitor(double threshold_m, int persist) : threshold_m_(threshold_m), persist_(persist) {}
  // Returns true when an alarm is raised: on the check that completes a streak.
  bool check(const RobotModel& model, const JointVector& expected, const JointVector& observed);
  bool check(double deviation_m);
  bool raised() const { return raised_; }
  int alarms() const { return alarms_; }
  double last_deviation_m() const { return last_m_; }
  double worst_deviation_m() const { return worst_m_; }

 private:
  double threshold_m_;
  int persist_;
  int over_ = 0;
  bool raised_ = false;
  int alarms_ = 0;
  double last_m_ = 0.0;
  double worst_m_ = 0.0;
};

// Distance between the tool positions of two joint states.
double tool_distance(const RobotModel& model, const JointVector& a, const JointVector& b);

// How far the tool really is from where the motor counts `counts` (Z, J2, J3) put it when
// the counts are `offset_steps` ahead of the motors (steps lost; what homing again measures).
double lost_steps_tool_offset_m(const RobotModel& model, const std::array<double, 3>& counts,
                                const std::array<std::int32_t, 3>& offset_steps, double wrist_deg);

// --- the twin against an instrument outside it (the emulator's truth, a tracker) -----------
// A tool position measured outside the twin, at a time of the robot's own clock (s).
struct ToolTruth {
  double t_s = 0.0;
  std::array<double, 3> p_m{};
};
// Joints the robot reported, at the time of its clock at which it sampled them (s).
struct TimedJoints {
  double t_s = 0.0;
  JointVector q{};
};
// Distances between the virtual robot's tool and a measured one.
struct ToolErrorStats {
  std::size_t count = 0;
  double mean_m = 0.0;
  double p95_m = 0.0;
  double max_m = 0.0;
};
// For each truth sample inside the span of the reports (sorted by time): the virtual robot's
// tool, FK of the description at the reported joints interpolated linearly in time, against
// the measured tool. Samples whose bracketing reports are more than `max_gap_s` apart are
// skipped (a gap in the reports is not an error of the twin).
// `distances_m`, when given, gets each compared sample's distance appended.
ToolErrorStats tool_error_vs_truth(const RobotModel& model, const std::vector<TimedJoints>& reports,
                                   const std::vector<ToolTruth>& truth, double max_gap_s = 0.05,
                                   std::vector<double>* distances_m = nullptr);
// Mean, 95th percentile (nearest rank) and maximum of distances (m).
ToolErrorStats error_stats(std::vector<double> distances_m);

}  // namespace scaratwin
