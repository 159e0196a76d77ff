// Typed message -> packet bytes for the four link directions, each packet from its row
// (messages.hpp, fields.hpp).
#include <cmath>
#include <string>
#include <string_view>
#include <tuple>
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
  void text(std::string_view s, const char* name) {
    if (s.empty() || s.size() > core::kMaxTextLength) {
      fail(name, "'" + std::string(s) + "'", "1..32 characters");
    }
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

  void fail(const char* name, const std::string& value, const char* valid) {
    if (!error_) {
      error_ = Error{protocol_error_code(core::kErrBadValue),
                     "encode " + code_ + ": " + name + " = " + value + "; valid: " + valid};
    }
  }

 private:
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

// One put() per kind of field (fields.hpp), each writing its member in its wire unit.
template <class M, class V, char K>
void put(Writer& w, const M& m, const field::Int<M, V, K>& f) {
  if constexpr (K == 'u') {
    w.u32(static_cast<std::uint32_t>(m.*f.member));
  } else {
    w.i32(static_cast<std::int32_t>(m.*f.member));
  }
}
template <class M>
void put(Writer& w, const M& m, const field::OptInt<M>& f) {
  w.opt(m.*f.member);
}
template <class M>
void put(Writer& w, const M& m, const field::Flag<M>& f) {
  w.i32(m.*f.member ? 1 : 0);
}
template <class M, class E>
void put(Writer& w, const M& m, const field::IntEnum<M, E>& f) {
  w.i32(static_cast<std::int32_t>(m.*f.member));
}
template <class M, class E>
void put(Writer& w, const M& m, const field::NameEnum<M, E>& f) {
  w.text(f.name_of(m.*f.member), f.name);
}
template <class M>
void put(Writer& w, const M& m, const field::Text<M>& f) {
  w.text(m.*f.member, f.name);
}
template <class M>
void put(Writer& w, const M& m, const field::Description<M>& f) {
  if (!(m.*f.member).empty()) w.description(m.*f.member);
}
template <class M>
void put(Writer& w, const M& m, const field::Length<M>& f) {
  w.m_as_mm(m.*f.member, f.name);
}
template <class M>
void put(Writer& w, const M& m, const field::Angle<M>& f) {
  w.rad_as_deg(m.*f.member, f.name);
}
template <class M>
void put(Writer& w, const M& m, const field::Joints<M>& f) {
  w.joints(m.*f.member);
}
template <class M>
void put(Writer& w, const M& m, const field::Centideg<M>& f) {
  w.rad_as_cdeg(m.*f.member, f.name);
}
template <class M>
void put(Writer& w, const M& m, const field::OptCentideg<M>& f) {
  if (m.*f.member) w.rad_as_cdeg(*(m.*f.member), f.name);
}
template <class M>
void put(Writer& w, const M& m, const field::Millis<M>& f) {
  w.s_as_ms(m.*f.member, f.name);
}
template <class M, class V>
void put(Writer& w, const M& m, const field::Steps<M, V>& f) {
  for (std::int32_t s : m.*f.member) w.i32(s);
}
template <class M>
void put(Writer& w, const M& m, const field::Robot<M>& f) {
  w.robot(m.*f.member);
}
// on TCP a hello's role and token come before its description hash ("-": no token)
void put(Writer& w, const Hello& m, const field::HelloAccess&) {
  if (!w.tcp()) return;
  const bool described = !m.description.empty();
  if (!m.role.empty() || !m.token.empty() || described) {
    w.text(m.role.empty() ? "control" : m.role, "role");
  }
  if (!m.token.empty() || described) w.text(m.token.empty() ? "-" : m.token, "token");
}
// after the description hash, which it needs (a field's place is its meaning)
void put(Writer& w, const Hello& m, const field::HelloRobot&) {
  if (!m.robot) return;
  if (!w.tcp()) {
    w.fail("robot", std::to_string(*m.robot), "none (the serial link reaches one robot)");
  } else if (m.description.empty()) {
    w.fail("robot", std::to_string(*m.robot), "none without a description hash");
  } else if (*m.robot < 0 || *m.robot > core::kMaxRobotIndex) {
    w.fail("robot", std::to_string(*m.robot), "0..255");
  } else {
    w.i32(*m.robot);
  }
}
void put(Writer& w, const Jog& m, const field::JogDelta&) {
  if (m.axis == Axis::kWrist) {
    w.rad_as_cdeg(m.delta, "delta (rad)");
  } else {
    w.whole(m.delta, "delta (steps)");
  }
}
void put(Writer& w, const JointWarning& m, const field::WarningValue&) {
  if (m.joint == 1) {
    w.m_as_mm(m.value, "value (m)");
  } else {
    w.rad_as_deg(m.value, "value (rad)");
  }
}
void put(Writer& w, const CameraShoot& m, const field::ShotSize&) {
  if (m.width_px != 0 || m.height_px != 0) {
    w.i32(m.width_px);
    w.i32(m.height_px);
  }
}
void put(Writer& w, const Image& m, const field::PayloadSize&) {
  w.i32(static_cast<std::int32_t>(m.png.size()));
}

// A packet: its code, then its fields in their row's order.
template <class M>
void put_packet(Writer& w, const M& m) {
  w.begin(M::kCode[0], M::kCode[1]);
  std::apply([&](const auto&... f) { (put(w, m, f), ...); }, M::fields());
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
        if constexpr (!std::is_same_v<std::decay_t<decltype(m)>, RealtimeCommand>) put_packet(w, m);
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

Result<std::string> encode(const SerialToDevice& m) { return encode_any(m); }
Result<std::string> encode(const SerialFromDevice& m) { return encode_any(m); }
Result<std::string> encode(const TcpToSim& m) { return encode_any(m); }
Result<std::string> encode(const TcpFromSim& m) { return encode_any(m); }
Status append(std::string& out, const SerialToDevice& m) { return append_any(out, m); }
Status append(std::string& out, const SerialFromDevice& m) { return append_any(out, m); }
Status append(std::string& out, const TcpToSim& m) { return append_any(out, m); }
Status append(std::string& out, const TcpFromSim& m) { return append_any(out, m); }

}  // namespace scaratwin::protocol
