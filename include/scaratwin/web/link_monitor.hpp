// Link figures for the browser UI: what the simulator knows about its virtual link to the hub
// (connected or not, joint frames received, frames lost, mirror latency) and the last joint
// values that arrived over it (the physical robot's, in the mirror mode).
//
// The simulator's protocol server feeds a LinkMonitor with every joint frame (JD/TJ) it
// applies: the frame's seq and the hub's t_us, and the time it was applied, both on this
// machine's steady clock in microseconds (transport::steady_now_us()). Latency is the
// difference modulo 2^32 (docs/protocol.md section 4); lost frames are sequence gaps
// (seq - last_seq - 1) mod 65536. Thread-safe: the server writes, the web feed reads.
#pragma once

#include <cstdint>
#include <deque>
#include <mutex>
#include <string>

#include "scaratwin/kinematics/kinematics.hpp"

namespace scaratwin::web {

// A snapshot of the link figures. Times in seconds.
struct LinkStatus {
  bool connected = false;       // a hub is attached to the virtual link
  std::uint64_t frames = 0;     // joint frames received since the monitor started
  std::uint64_t lost = 0;       // frames missing (sequence gaps)
  bool has_latency = false;     // false until a frame arrived
  double latency_last_s = 0.0;  // last frame: applied time - hub's sample time
  double latency_mean_s = 0.0;  // mean over the frames of the last window
  double latency_max_s = 0.0;   // largest over the last window
  double frame_rate_hz = 0.0;   // frames per second over the last window
  bool has_physical = false;    // true once a joint frame arrived
  JointVector physical{};       // last joint values received (m, rad)
  double physical_age_s = 0.0;  // time since they arrived
  std::string twin_mode;        // "mirror", "control" or "prediction"; empty: derive from the sim
};

class LinkMonitor {
 public:
  // window_s: the span over which mean, max and rate are computed.
  explicit LinkMonitor(double window_s = 1.0) : window_us_(window_s * 1e6) {}

  // A joint frame with sequence number `seq` (0..65535), sampled at `t_us` (hub's steady
  // clock mod 2^32) carrying joints `q`, applied at `applied_us` (steady clock of this
  // machine, full width).
  void on_joint_frame(std::uint16_t seq, std::uint32_t t_us, const JointVector& q,
                      std::int64_t applied_us);
  // A hub attached (true) or left (false). A new connection restarts the sequence tracking;
  // a hub that leaves takes the twin mode it set with it.
  void set_connected(bool connected);
  // The frames that follow are a new stream (a hub's hello, a mode switch): the gap between
  // the last frame and the next one is no loss.
  void restart_sequence();
  // What the hub says the twin is doing ("mirror", "control", "prediction"), or "" to let
  // the UI derive it from the simulator mode.
  void set_twin_mode(std::string mode);

  // The figures at `now_us` (steady clock, us), or now.
  LinkStatus status(std::int64_t now_us) const;
  LinkStatus status() const;

 private:
  struct Sample {
    std::int64_t applied_us;
    double latency_s;
  };
  void trim(std::int64_t now_us);

  const double window_us_;
  mutable std::mutex mutex_;
  LinkStatus status_;
  bool have_seq_ = false;
  std::uint16_t last_seq_ = 0;
  std::int64_t physical_us_ = 0;
  std::deque<Sample> window_;
};

}  // namespace scaratwin::web
