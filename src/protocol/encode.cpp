// Typed message -> packet bytes for the four link directions.
#include <cmath>
#include <string>
#include <type_traits>

#include "scaratwin/protocol/codec.hpp"
#include "wire_units.hpp"

namespace scaratwin::protocol {
namespace {

using core::code_id;

// Writes one packet through the core encoder, converting SI values to wire units and
// remembering the first value that the wire cannot carry.
class Writer {
 public:
  Writer(const core::LinkSpec& link, char* buffer, std::size_t capacity)
      : encoder_(link, buffer, capacity), tcp_(link.delimiter == ',') {}

  bool tcp() const { return tcp_; }

  void begin(char a, char b) {
    code_ = std::string{a, b};
    encoder_.begin(code_id(a, b));
  }
  void i32(std::int32_t v) { encoder_.add_i32(v); }
  void u32(std::uint32_t v) { encoder_.add_u32(v); }
  void text(const std::string& s, const char* name) {
    if (s.empty() || s.size() > core::kMaxTextLength) fail(name, "'" + s + "'", "1..32 characters");
    encoder_.add_text(s.data(), s.size());
  }
  // a description hash: 8 lower-case hex digits
  void description(const std::string& s) {
    const bool ok = s.size() == 8 && s.find_first_not_of("0123456789abcdef") == std::string::npos;
    if (!ok) fail("description", "'" + s + "'", "8 lower-case hex digits");
    encoder_.add_text(s.data(), s.size());
  }
  // the robot index of a robot-addressed packet: only on TCP, and only when not 0 (a packet
  // without one addresses robot 0, so robot 0's packets are version 1's)
  void robot(std::int32_t index) {
    if (index == 0) return;
    if (!tcp_) {
      fail("robot", std::to_string(index), "0 (the serial link reaches one robot)");
    } else if (index < 0 || index > core::kMaxRobotIndex) {
      fail("robot", std::to_string(index), "0..255");
    }
    encoder_.add_i32(index);
  }
  void opt(const std::optional<std::int32_t>& v) {
    if (v) i32(*v);
  }
  // integer-valued double (jog steps)
  void whole(double v, const char* name) { put_int(wire::round_i32(v), v, name, "a finite int32"); }
  void m_as_mm(double m, const char* name) {
    put_fixed(wire::m_to_scaled_mm(m), wire::kMmDecimals, m, name, "finite, |mm| < 2.1e6");
  }
  void rad_as_deg(double rad, const char* name) {
    put_fixed(wire::rad_to_scaled_deg(rad), wire::kDegDecimals, rad, name, "finite, |deg| < 2.1e5");
  }
  void rad_as_cdeg(double rad, const char* name) {
    put_int(wire::rad_to_cdeg(rad), rad, name, "finite, |cdeg| < 2^31");
  }
  void s_as_ms(double s, const char* name) {
    put_int(wire::s_to_ms(s), s, name, "finite, |ms| < 2^31");
  }
  void joints(const JointVector& q) {
    m_as_mm(q[0], "q[0] (d1, m)");
    rad_as_deg(q[1], "q[1] (q2, rad)");
    rad_as_deg(q[2], "q[2] (q3, rad)");
    rad_as_deg(q[3], "q[3] (q4, rad)");
  }

  // Finishes the packet and appends it to `out`.
  Status finish(std::string& out) {
    if (!error_ && !encoder_.end()) {
      const std::uint8_t e = encoder_.error();
      error_ = Error{protocol_error_code(e), "encode " + code_ + ": " + core::error_name(e)};
    }
    if (error_) return *error_;
    out.append(encoder_.data(), encoder_.size());
    return Ok{};
  }

 private:
  void fail(const char* name, const std::string& value, const char* valid) {
    if (!error_) {
      error_ = Error{protocol_error_code(core::kErrBadValue),
                     "encode " + code_ + ": " + name + " = " + value + "; valid: " + valid};
    }
  }
  void put_int(std::optional<std::int32_t> v, double raw, const char* name, const char* valid) {
    if (!v) {
      fail(name, std::to_string(raw), valid);
      return;
    }
    encoder_.add_i32(*v);
  }
  void put_fixed(std::optional<std::int32_t> v, std::uint8_t decimals, double raw, const char* name,
                 const char* valid) {
    if (!v) {
      fail(name, std::to_string(raw), valid);
      return;
    }
    encoder_.add_fixed(*v, decimals);
  }

  core::Encoder encoder_;
  bool tcp_;
  std::string code_;
  std::optional<Error> error_;
};

// shared ------------------------------------------------------------------------------------
void put(Writer& w, const Hello& m) {
  w.begin('H', 'I');
  w.i32(m.version);
  // on TCP the description hash follows the role and the token ("-": none)
  const bool described = !m.description.empty();
  if (w.tcp() && (!m.role.empty() || !m.token.empty() || described)) {
    w.text(m.role.empty() ? "control" : m.role, "role");
  }
  if (w.tcp() && (!m.token.empty() || described)) w.text(m.token.empty() ? "-" : m.token, "token");
  if (described) w.description(m.description);
}
void put(Writer& w, const PeerHello& m) {
  w.begin('H', 'I');
  w.i32(m.version);
  w.text(m.device, "device");
  w.text(m.software_version, "software_version");
  if (!m.description.empty()) w.description(m.description);
}
void put(Writer& w, const Ping& m) {
  w.begin('P', 'I');
  w.opt(m.token);
}
void put(Writer& w, const QueryState& m) {
  w.begin('Q', 'S');
  w.robot(m.robot);
}
void put(Writer& w, const Stop& m) {
  w.begin('S', 'P');
  w.robot(m.robot);
}
void put(Writer& w, const Ack& m) {
  w.begin('A', 'K');
  w.text(m.code, "code");
  w.opt(m.value);
}
void put(Writer& w, const ErrorReply& m) {
  w.begin('E', 'R');
  w.i32(m.code);
  w.opt(m.detail);
}

// serial ------------------------------------------------------------------------------------
void put(Writer& w, const SetReportRate& m) {
  w.begin('S', 'R');
  w.i32(m.rate_hz);
}
void put(Writer& w, const Home&) { w.begin('H', 'M'); }
void put(Writer& w, const TrajectoryBegin& m) {
  w.begin('T', 'B');
  w.i32(m.points);
}
void put(Writer& w, const TrajectoryPoint& m) {
  w.begin('T', 'P');
  w.i32(m.seq);
  w.s_as_ms(m.dt_s, "dt_s");
  for (std::int32_t s : m.steps) w.i32(s);
  w.rad_as_cdeg(m.wrist_rad, "wrist_rad");
  if (m.grip_rad) w.rad_as_cdeg(*m.grip_rad, "grip_rad");
}
void put(Writer& w, const SetGripper& m) {
  w.begin('G', 'R');
  w.rad_as_cdeg(m.angle_rad, "angle_rad");
}
void put(Writer& w, const Jog& m) {
  w.begin('J', 'G');
  w.i32(static_cast<std::int32_t>(m.axis));
  if (m.axis == Axis::kWrist) {
    w.rad_as_cdeg(m.delta, "delta (rad)");
  } else {
    w.whole(m.delta, "delta (steps)");
  }
}
void put(Writer& w, const Config& m) {
  w.begin('C', 'F');
  w.i32(m.key);
  w.opt(m.value);
}
void put(Writer& w, const DeviceState& m) {
  w.begin('S', 'T');
  w.i32(m.seq);
  w.u32(m.t_us);
  for (std::int32_t s : m.steps) w.i32(s);
  w.rad_as_cdeg(m.wrist_rad, "wrist_rad");
  w.rad_as_cdeg(m.grip_rad, "grip_rad");
  w.u32(m.flags);
  w.i32(m.queue_free);
}
void put(Writer& w, const DeviceEvent& m) {
  w.begin('E', 'V');
  w.i32(static_cast<std::int32_t>(m.event));
  w.opt(m.value);
}

// TCP ---------------------------------------------------------------------------------------
void put(Writer& w, const JointData& m) {
  w.begin('J', 'D');
  w.i32(m.seq);
  w.u32(m.t_us);
  w.joints(m.q);
  w.robot(m.robot);
}
void put(Writer& w, const JointTargets& m) {
  w.begin('T', 'J');
  w.i32(m.seq);
  w.u32(m.t_us);
  w.joints(m.q);
  w.robot(m.robot);
}
void put(Writer& w, const SetMode& m) {
  w.begin('M', 'D');
  w.text(mode_name(m.mode), "mode");
  w.robot(m.robot);
}
void put(Writer& w, const SetTwinPhase& m) {
  w.begin('T', 'W');
  w.text(phase_name(m.phase), "phase");
  w.robot(m.robot);
}
void put(Writer& w, const Grasp& m) {
  w.begin('G', 'R');
  w.i32(m.close ? 1 : 0);
  w.robot(m.robot);
}
void put(Writer& w, const CameraShoot& m) {
  w.begin('C', 'S');
  if (m.width_px != 0 || m.height_px != 0) {
    w.i32(m.width_px);
    w.i32(m.height_px);
  }
}
void put(Writer& w, const SpawnCube& m) {
  w.begin('S', 'C');
  w.text(color_name(m.color), "color");
  w.m_as_mm(m.x_m, "x_m");
  w.m_as_mm(m.y_m, "y_m");
}
void put(Writer& w, const ResetScene&) { w.begin('R', 'S'); }
void put(Writer& w, const QueryObjects& m) {
  w.begin('O', 'P');
  w.opt(m.id);
}
void put(Writer& w, const JointApplied& m) {
  w.begin('J', 'A');
  w.i32(m.seq);
  w.u32(m.t_apply_us);
  w.robot(m.robot);
}
void put(Writer& w, const GripperState& m) {
  w.begin('G', 'R');
  w.i32(m.closed ? 1 : 0);
  w.i32(m.held_id);
  w.robot(m.robot);
}
void put(Writer& w, const Image& m) {
  w.begin('I', 'M');
  w.i32(static_cast<std::int32_t>(m.png.size()));
}
void put(Writer& w, const ObjectPose& m) {
  w.begin('O', 'P');
  w.i32(m.id);
  w.text(color_name(m.color), "color");
  w.m_as_mm(m.x_m, "x_m");
  w.m_as_mm(m.y_m, "y_m");
  w.m_as_mm(m.z_m, "z_m");
  w.rad_as_deg(m.yaw_rad, "yaw_rad");
}
void put(Writer& w, const SimState& m) {
  w.begin('S', 'T');
  w.i32(m.seq);
  w.u32(m.t_us);
  w.joints(m.q);
  w.i32(m.grip_closed ? 1 : 0);
  w.i32(m.held_id);
  w.text(mode_name(m.mode), "mode");
  w.robot(m.robot);
}
void put(Writer& w, const JointWarning& m) {
  w.begin('J', 'W');
  w.i32(m.joint);
  if (m.joint == 1) {
    w.m_as_mm(m.value, "value (m)");
  } else {
    w.rad_as_deg(m.value, "value (rad)");
  }
  w.robot(m.robot);
}

template <typename Direction>
Status append_any(std::string& out, const Direction& message) {
  if constexpr (std::is_same_v<Direction, SerialToDevice>) {
    if (const auto* rt = std::get_if<RealtimeCommand>(&message)) {
      out += static_cast<char>(rt->command);
      return Ok{};
    }
  }
  if constexpr (std::is_same_v<Direction, TcpFromSim>) {
    if (const auto* image = std::get_if<Image>(&message)) {
      if (image->png.size() > core::kMaxImageBytes) {
        return Error{protocol_error_code(core::kErrPayloadTooLarge),
                     "encode IM: " + std::to_string(image->png.size()) +
                         " bytes of PNG; valid: at most " + std::to_string(core::kMaxImageBytes)};
      }
    }
  }
  char buffer[core::kTcpMaxLine];
  Writer w(detail::link_of<Direction>(), buffer, sizeof buffer);
  std::visit(
      [&w](const auto& m) {
        if constexpr (!std::is_same_v<std::decay_t<decltype(m)>, RealtimeCommand>) put(w, m);
      },
      message);
  Status s = w.finish(out);
  if (!s) return s;
  if constexpr (std::is_same_v<Direction, TcpFromSim>) {
    if (const auto* image = std::get_if<Image>(&message)) {
      out.append(reinterpret_cast<const char*>(image->png.data()), image->png.size());
    }
  }
  return Ok{};
}

template <typename Direction>
Result<std::string> encode_any(const Direction& message) {
  std::string out;
  Status s = append_any(out, message);
  if (!s) return s.error();
  return out;
}

}  // namespace

const char* mode_name(SimMode mode) { return mode == SimMode::kMirror ? "mirror" : "simulate"; }

const char* phase_name(TwinPhase phase) {
  switch (phase) {
    case TwinPhase::kMirror:
      return "mirror";
    case TwinPhase::kControl:
      return "control";
    case TwinPhase::kPrediction:
      return "prediction";
    case TwinPhase::kHoming:
      return "homing";
    case TwinPhase::kNone:
      break;
  }
  return "none";
}

Result<std::string> encode(const SerialToDevice& m) { return encode_any(m); }
Result<std::string> encode(const SerialFromDevice& m) { return encode_any(m); }
Result<std::string> encode(const TcpToSim& m) { return encode_any(m); }
Result<std::string> encode(const TcpFromSim& m) { return encode_any(m); }
Status append(std::string& out, const SerialToDevice& m) { return append_any(out, m); }
Status append(std::string& out, const SerialFromDevice& m) { return append_any(out, m); }
Status append(std::string& out, const TcpToSim& m) { return append_any(out, m); }
Status append(std::string& out, const TcpFromSim& m) { return append_any(out, m); }

}  // namespace scaratwin::protocol
