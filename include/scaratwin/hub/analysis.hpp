// Twin figures from recorded data: mirror latency statistics, the deviation between two runs
// of the same plan (prediction vs physical replay, virtual vs physical), and the desync alarm.
// Pure: no I/O, no clock.
#pragma once

#include <vector>

#include "scaratwin/hub/twin_db.hpp"
#include "scaratwin/kinematics/kinematics.hpp"

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

// Joint state of a recorded series at time t (linear interpolation, clamped).
JointVector interpolate(const std::vector<JointRecord>& series, double t_s);

// Desync alarm: raised when the tool deviation between the expected and the observed pose
// stays above `threshold_m` for `persist` consecutive checks.
class DesyncMonitor {
 public:
  DesyncMonitor(double threshold_m, int persist) : threshold_m_(threshold_m), persist_(persist) {}
  // Returns true exactly once, when the alarm is raised.
  bool check(const RobotModel& model, const JointVector& expected, const JointVector& observed);
  bool raised() const { return raised_; }
  double last_deviation_m() const { return last_m_; }
  double worst_deviation_m() const { return worst_m_; }

 private:
  double threshold_m_;
  int persist_;
  int over_ = 0;
  bool raised_ = false;
  double last_m_ = 0.0;
  double worst_m_ = 0.0;
};

// Distance between the tool positions of two joint states.
double tool_distance(const RobotModel& model, const JointVector& a, const JointVector& b);

}  // namespace scaratwin
