// The simulator's end of the virtual link: a TCP server (default 127.0.0.1:55016) that speaks
// the protocol of docs/protocol.md section 7 for a World. Every line gets exactly one reply in
// order (OP: one per object, then AK); joint-limit warnings (JW) go out unsolicited before the
// reply of the packet that caused them. A line that does not decode gets its ER reply and
// never reaches the simulation, so the scene stays untouched.
//
// Pacing: with World speed 1 (real time) a TJ is a servo target applied at once. With speed 0
// (`--speed max`, prediction) consecutive TJ packets form a timed stream (their t_us offsets
// from the first one) that the simulation plays in lockstep as fast as it can: it never runs
// past the last target received, so a run depends only on the packets, not on their timing.
// A GR during a stream acts at the stream's last target. SP or MD ends the stream.
//
// Refusals (ER code, detail): JD in simulate mode or TJ in mirror mode -> 9 busy; an unknown
// object id, a spawn off the table or on another cube, an image size beyond the offscreen
// buffer -> 11 bad_value (detail: field index); a colour whose cube pool is used up -> 6
// queue_full (detail 0); a protocol version other than 1 -> 13 (detail 1); a render failure
// -> 15 internal.
#pragma once

#include <atomic>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>

#include "scaratwin/core/result.hpp"
#include "scaratwin/sim/world.hpp"

namespace scaratwin::transport {
class TcpServer;
class IoThread;
}  // namespace scaratwin::transport

namespace scaratwin::sim {

// A joint frame (JD or TJ) as applied, for link figures (latency, lost frames).
struct JointFrame {
  std::uint16_t seq = 0;
  std::uint32_t t_us = 0;       // the hub's sample time (its steady clock, mod 2^32)
  JointVector q{};              // the values received (m, rad)
  std::int64_t applied_us = 0;  // when applied (transport::steady_now_us(), the same clock)
  int robot = 0;                // the robot's index in the workcell
};

struct ServerOptions {
  std::string bind_address = "127.0.0.1";
  std::uint16_t port = 55016;   // 0: an ephemeral port (see SimServer::port())
  std::string save_images_dir;  // if set, every shot is also saved there as shot_<n>.png
  // Access (docs/security.md). With a token, every connection must open with
  // `HI,1,control|observe,<token>,`; without one, anything but HTTP is admitted. One
  // controlling client at a time: a second one is refused (ER,18,2) unless it says
  // `HI,1,observe,...`, or, in a workcell, names in its hello a robot nobody drives (then it
  // drives that robot only); an observer may only query (HI, PI, QS, OP, AC). A connection
  // whose first line is an HTTP request is closed unanswered and nothing of it runs.
  std::string token;  // [A-Za-z0-9_.-]{1,32}, or empty
  // Called on the io thread after every joint frame the simulation accepted (may be empty).
  std::function<void(const JointFrame&)> on_joint_frame;
  // Called on the io thread when the hub says what the twin is doing (TW): "mirror",
  // "control", "prediction", or "" for none (may be empty).
  std::function<void(const std::string&)> on_twin_phase;
  // Called on the io thread when robot `robot`'s joint frames that follow are a new stream,
  // whose sequence numbers do not continue the last one's: a hub's hello (HI, the first packet
  // of a connection: for every robot it drives) or a mode switch (MD) (may be empty).
  std::function<void(int robot)> on_new_stream;
};

struct ServerCounters {
  std::uint64_t packets = 0;       // lines handled
  std::uint64_t errors_sent = 0;   // ER replies
  std::uint64_t joint_frames = 0;  // JD and TJ applied
  std::uint64_t images_sent = 0;
  std::uint64_t warnings_sent = 0;  // JW packets
};

class SimServer {
 public:
  // Binds and listens before returning; serves on its own io thread.
  static Result<std::unique_ptr<SimServer>> create(World& world, const ServerOptions& options);
  ~SimServer();
  SimServer(const SimServer&) = delete;
  SimServer& operator=(const SimServer&) = delete;

  std::uint16_t port() const;
  bool peer_connected() const;
  // A controlling client drives robot `robot` (the whole simulator's, or that robot's own).
  // Any thread.
  bool robot_controlled(int robot) const;
  ServerCounters counters() const;

  // Handles one received line (without '\n') and returns the reply bytes: what the io thread
  // does for every packet. Public for tests and for in-process use.
  std::string handle_line(const std::string& line);

 private:
  explicit SimServer(World& world, ServerOptions options);
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace scaratwin::sim
