// The paper's companion TCP dialect, served by the simulator beside protocol v1, so that the
// authors' MATLAB scripts (and GNU Octave running them) drive scaratwin's virtual robot as they
// drove their Unity server. docs/protocol.md section 13 is the reference.
//
// Framing: one length byte (1..255), then that many bytes of ASCII `Command:arg,arg,...`.
// Commands: Name, ModRobot (d1 in metres, joints 2..4 in degrees), ModGrab, NewObj, Camera
// (answered with the raw PNG bytes, no length). Nothing else is ever sent. A bad frame is
// logged with its reason and changes nothing; the connection stays up.
//
// The pure parts (CompanionFramer, parse_companion) have no I/O; CompanionServer listens on its
// own TCP port and applies the commands to a World.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <string_view>

#include "scaratwin/core/result.hpp"
#include "scaratwin/kinematics/robot_model.hpp"
#include "scaratwin/sim/world.hpp"

namespace scaratwin::sim {

// Cuts a byte stream into length-prefixed frames; any chunking gives the same frames.
class CompanionFramer {
 public:
  // Feeds bytes: on_frame(payload) for every complete frame, on_error(reason) for a length
  // byte of 0 (skipped: the next byte is a length byte again).
  void feed(std::string_view bytes, const std::function<void(std::string_view)>& on_frame,
            const std::function<void(const std::string&)>& on_error);
  // Bytes of an incomplete frame held (0 between frames).
  std::size_t pending() const { return have_ ? payload_.size() + 1 : 0; }
  std::size_t expected() const { return have_ ? need_ : 0; }

 private:
  bool have_ = false;  // a length byte was read
  std::size_t need_ = 0;
  std::string payload_;
};

// One decoded companion command.
struct CompanionCommand {
  enum class Kind { kName, kModRobot, kModGrab, kNewObj, kCamera };
  Kind kind = Kind::kName;
  std::string name;                   // kName: the client's name
  JointVector q{};                    // kModRobot: d1 (m), q2..q4 (rad)
  bool grab = false;                  // kModGrab: true grasp, false release
  CubeColor color = CubeColor::kRed;  // kNewObj
  std::string camera, path, file;     // kCamera: the three fields as sent
};

// Decodes one frame's payload. Errors (Error::message names the problem, the field and what
// would be valid): not printable ASCII, no ':', an unknown command, the wrong number of
// fields, a field that is not a number in the invariant culture (digits, optional sign,
// '.' decimals, optional exponent; NaN and infinity refused), a ModRobot joint outside the
// robot's limits, a ModGrab other than 0/1, a NewObj other than 1/2/3.
Result<CompanionCommand> parse_companion(std::string_view payload, const RobotModel& robot);

struct CompanionOptions {
  std::string bind_address = "127.0.0.1";
  std::uint16_t port = 55012;    // the companion scripts' port; 0: an ephemeral port
  std::uint64_t spawn_seed = 1;  // the random spots NewObj spawns cubes at
  // Where log lines go (each without '\n'); empty: stderr, prefixed "scaratwin-sim: companion: ".
  std::function<void(const std::string&)> log;
};

struct CompanionCounters {
  std::uint64_t frames = 0;   // frames carried out or refused (good and bad), zero length bytes too
  std::uint64_t refused = 0;  // logged as bad, nothing changed
  std::uint64_t applied = 0;  // commands carried out
  std::uint64_t images_sent = 0;
  std::uint64_t clients = 0;  // connections accepted so far
};

class CompanionServer {
 public:
  // Binds and listens before returning; serves any number of clients on its own io thread.
  static Result<std::unique_ptr<CompanionServer>> create(World& world,
                                                         const CompanionOptions& options);
  ~CompanionServer();
  CompanionServer(const CompanionServer&) = delete;
  CompanionServer& operator=(const CompanionServer&) = delete;

  std::uint16_t port() const;
  CompanionCounters counters() const;

 private:
  CompanionServer();
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace scaratwin::sim
