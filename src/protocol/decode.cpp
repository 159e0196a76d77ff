// Packet -> typed message for the four link directions, with the per-code value checks, and
// the messages of decode errors.
#include <string>

#include "scaratwin/protocol/codec.hpp"
#include "wire_units.hpp"

namespace scaratwin::protocol::detail {
namespace {

using core::code_id;
using core::Packet;

std::string code_text(std::uint16_t code) {
  return std::string{static_cast<char>(code >> 8), static_cast<char>(code & 0xff)};
}

// Printable excerpt of a rejected line: at most 48 bytes, other bytes as \xNN.
std::string excerpt(const char* s, std::size_t n) {
  static constexpr char kHex[] = "0123456789abcdef";
  std::string out;
  const std::size_t shown = n < 48 ? n : 48;
  for (std::size_t i = 0; i < shown; ++i) {
    const auto c = static_cast<unsigned char>(s[i]);
    if (c >= 0x20 && c < 0x7f) {
      out += static_cast<char>(c);
    } else {
      out += "\\x";
      out += kHex[c >> 4];
      out += kHex[c & 15];
    }
  }
  if (shown < n) out += "...";
  return out;
}

std::string field_text(const Packet& p, std::uint8_t i) {
  return std::string(p.text(i), p.field_length[i]);
}

DecodeError bad_value(const Packet& p, std::uint8_t i, const std::string& valid) {
  return DecodeError{core::kErrBadValue, i,
                     code_text(p.code) + " field " + std::to_string(i) + " is " + field_text(p, i) +
                         "; valid: " + valid};
}

// Range check of an integer field; sets *error on failure.
bool in_range(const Packet& p, std::uint8_t i, std::int64_t lo, std::int64_t hi,
              std::optional<DecodeError>* error) {
  const std::int64_t v = p.i32(i);
  if (v >= lo && v <= hi) return true;
  *error = bad_value(p, i, std::to_string(lo) + ".." + std::to_string(hi));
  return false;
}

std::optional<std::int32_t> optional_field(const Packet& p, std::uint8_t i) {
  if (i < p.field_count) return p.i32(i);
  return std::nullopt;
}

// The robot index in optional field i of a robot-addressed TCP packet: 0 when the packet has
// none (a v1 packet addresses robot 0).
std::int32_t robot_of(const Packet& p, std::uint8_t i, std::optional<DecodeError>* error) {
  if (i >= p.field_count) return 0;
  if (!*error) in_range(p, i, 0, core::kMaxRobotIndex, error);
  return p.i32(i);
}

std::uint16_t seq_of(const Packet& p, std::uint8_t i) {
  return static_cast<std::uint16_t>(p.i32(i));
}

JointVector joints_of(const Packet& p, std::uint8_t first) {
  return JointVector{wire::mm_field_to_m(p, first), wire::deg_field_to_rad(p, first + 1),
                     wire::deg_field_to_rad(p, first + 2), wire::deg_field_to_rad(p, first + 3)};
}

bool parse_mode(const Packet& p, std::uint8_t i, SimMode* mode) {
  if (p.text_equals(i, "mirror")) {
    *mode = SimMode::kMirror;
  } else if (p.text_equals(i, "simulate")) {
    *mode = SimMode::kSimulate;
  } else {
    return false;
  }
  return true;
}

bool parse_color_field(const Packet& p, std::uint8_t i, CubeColor* color) {
  for (int c = 0; c < kNumColors; ++c) {
    if (p.text_equals(i, color_name(static_cast<CubeColor>(c)))) {
      *color = static_cast<CubeColor>(c);
      return true;
    }
  }
  return false;
}

bool is_code_text(const Packet& p, std::uint8_t i) {
  const char* s = p.text(i);
  return p.field_length[i] == 2 && s[0] >= 'A' && s[0] <= 'Z' && s[1] >= 'A' && s[1] <= 'Z';
}

// The message, constructed in place (no temporary variant to move).
template <typename Direction, typename T>
Decoded<Direction> make(T&& message) {
  return Decoded<Direction>(std::in_place_index<0>, std::forward<T>(message));
}

template <typename Direction, typename T>
Decoded<Direction> checked(std::optional<DecodeError>& error, T&& message) {
  if (error) return Decoded<Direction>(std::in_place_index<1>, std::move(*error));
  return make<Direction>(std::forward<T>(message));
}

// replies shared by both links
template <typename Direction>
Decoded<Direction> ack_or_error(const Packet& p) {
  if (p.code == code_id('A', 'K')) {
    if (!is_code_text(p, 0)) return bad_value(p, 0, "a two-letter upper-case code");
    return make<Direction>(Ack{field_text(p, 0), optional_field(p, 1)});
  }
  std::optional<DecodeError> error;
  in_range(p, 0, 1, 255, &error);
  return checked<Direction>(error, ErrorReply{p.i32(0), optional_field(p, 1)});
}

// A description hash field: 8 lower-case hex digits (docs/protocol.md section 11).
bool is_description(const Packet& p, std::uint8_t i) {
  if (p.field_length[i] != 8) return false;
  const char* s = p.text(i);
  for (int k = 0; k < 8; ++k) {
    if (!((s[k] >= '0' && s[k] <= '9') || (s[k] >= 'a' && s[k] <= 'f'))) return false;
  }
  return true;
}

// The optional description hash in field i of a hello, "" when the hello has none.
template <typename Direction>
std::optional<Decoded<Direction>> description_field(const Packet& p, std::uint8_t i,
                                                    std::string* out) {
  if (p.field_count <= i) return std::nullopt;
  if (!is_description(p, i)) {
    return Decoded<Direction>(std::in_place_index<1>,
                              bad_value(p, i, "a description hash of 8 lower-case hex digits"));
  }
  *out = field_text(p, i);
  return std::nullopt;
}

template <typename Direction>
Decoded<Direction> peer_hello(const Packet& p) {
  PeerHello hi{p.i32(0), field_text(p, 1), field_text(p, 2), {}};
  if (auto bad = description_field<Direction>(p, 3, &hi.description)) return std::move(*bad);
  return make<Direction>(std::move(hi));
}

}  // namespace

Decoded<SerialToDevice> to_message(const Packet& p, SerialToDevice*) {
  using M = SerialToDevice;
  std::optional<DecodeError> error;
  switch (p.code) {
    case code_id('H', 'I'): {
      Hello hello{p.i32(0), {}, {}, {}};
      if (auto bad = description_field<M>(p, 1, &hello.description)) return std::move(*bad);
      return make<M>(std::move(hello));
    }
    case code_id('P', 'I'):
      return make<M>(Ping{optional_field(p, 0)});
    case code_id('S', 'R'):
      in_range(p, 0, 0, 1000, &error);
      return checked<M>(error, SetReportRate{p.i32(0)});
    case code_id('Q', 'S'):
      return make<M>(QueryState{});
    case code_id('H', 'M'):
      return make<M>(Home{});
    case code_id('T', 'B'):
      in_range(p, 0, 1, 65535, &error);
      return checked<M>(error, TrajectoryBegin{p.i32(0)});
    case code_id('T', 'P'): {
      in_range(p, 0, 0, 65534, &error) && in_range(p, 1, 1, 65535, &error) &&
          in_range(p, 5, 0, 18000, &error) &&
          (p.field_count < 7 || in_range(p, 6, 0, 18000, &error));
      TrajectoryPoint t;
      t.seq = p.i32(0);
      t.dt_s = wire::ms_to_s(p.i32(1));
      t.steps = {p.i32(2), p.i32(3), p.i32(4)};
      t.wrist_rad = wire::cdeg_to_rad(p.i32(5));
      if (p.field_count == 7) t.grip_rad = wire::cdeg_to_rad(p.i32(6));
      return checked<M>(error, t);
    }
    case code_id('G', 'R'):
      in_range(p, 0, 0, 18000, &error);
      return checked<M>(error, SetGripper{wire::cdeg_to_rad(p.i32(0))});
    case code_id('J', 'G'): {
      in_range(p, 0, 0, 3, &error);
      const auto axis = static_cast<Axis>(p.i32(0));
      const double delta = axis == Axis::kWrist ? wire::cdeg_to_rad(p.i32(1)) : p.i32(1);
      return checked<M>(error, Jog{axis, delta});
    }
    case code_id('S', 'P'):
      return make<M>(Stop{});
    case code_id('C', 'F'):
      // the firmware's keys 1..11 (docs/firmware.md); their values are the firmware's to judge
      in_range(p, 0, 1, 11, &error);
      return checked<M>(error, Config{p.i32(0), optional_field(p, 1)});
    default:
      break;
  }
  return DecodeError{core::kErrInternal, 0, "no typed message for code " + code_text(p.code)};
}

Decoded<SerialFromDevice> to_message(const Packet& p, SerialFromDevice*) {
  using M = SerialFromDevice;
  std::optional<DecodeError> error;
  switch (p.code) {
    case code_id('H', 'I'):
      return peer_hello<M>(p);
    case code_id('S', 'T'): {
      in_range(p, 0, 0, 65535, &error) && in_range(p, 7, 0, 0x7fffffff, &error) &&
          in_range(p, 8, 0, 65535, &error);
      DeviceState s;
      s.seq = seq_of(p, 0);
      s.t_us = p.u32(1);
      s.steps = {p.i32(2), p.i32(3), p.i32(4)};
      s.wrist_rad = wire::cdeg_to_rad(p.i32(5));
      s.grip_rad = wire::cdeg_to_rad(p.i32(6));
      s.flags = p.u32(7);
      s.queue_free = p.i32(8);
      return checked<M>(error, s);
    }
    case code_id('A', 'K'):
    case code_id('E', 'R'):
      return ack_or_error<M>(p);
    case code_id('E', 'V'):
      in_range(p, 0, 1, kLastDeviceEvent, &error);
      return checked<M>(error,
                        DeviceEvent{static_cast<DeviceEventCode>(p.i32(0)), optional_field(p, 1)});
    default:
      break;
  }
  return DecodeError{core::kErrInternal, 0, "no typed message for code " + code_text(p.code)};
}

Decoded<TcpToSim> to_message(const Packet& p, TcpToSim*) {
  using M = TcpToSim;
  std::optional<DecodeError> error;
  switch (p.code) {
    case code_id('H', 'I'): {
      Hello hello{p.i32(0), {}, {}, {}};
      if (p.field_count > 1) {
        if (!p.text_equals(1, "control") && !p.text_equals(1, "observe")) {
          return bad_value(p, 1, "control or observe");
        }
        hello.role = field_text(p, 1);
      }
      // "-": no token (a hello that carries a description hash but no token)
      if (p.field_count > 2 && !p.text_equals(2, "-")) hello.token = field_text(p, 2);
      if (auto bad = description_field<M>(p, 3, &hello.description)) return std::move(*bad);
      return make<M>(std::move(hello));
    }
    case code_id('P', 'I'):
      return make<M>(Ping{optional_field(p, 0)});
    case code_id('J', 'D'):
    case code_id('T', 'J'): {
      in_range(p, 0, 0, 65535, &error);
      const std::int32_t robot = robot_of(p, 6, &error);
      if (error) return std::move(*error);
      if (p.code == code_id('J', 'D'))
        return make<M>(JointData{seq_of(p, 0), p.u32(1), joints_of(p, 2), robot});
      return make<M>(JointTargets{seq_of(p, 0), p.u32(1), joints_of(p, 2), robot});
    }
    case code_id('M', 'D'): {
      SetMode m;
      if (!parse_mode(p, 0, &m.mode)) return bad_value(p, 0, "mirror, simulate");
      m.robot = robot_of(p, 1, &error);
      return checked<M>(error, m);
    }
    case code_id('T', 'W'): {
      for (TwinPhase t : {TwinPhase::kNone, TwinPhase::kMirror, TwinPhase::kControl,
                          TwinPhase::kPrediction, TwinPhase::kHoming}) {
        if (p.text_equals(0, phase_name(t))) {
          const std::int32_t robot = robot_of(p, 1, &error);
          return checked<M>(error, SetTwinPhase{t, robot});
        }
      }
      return bad_value(p, 0, "none, mirror, control, prediction, homing");
    }
    case code_id('G', 'R'): {
      in_range(p, 0, 0, 1, &error);
      const std::int32_t robot = robot_of(p, 1, &error);
      return checked<M>(error, Grasp{p.i32(0) == 1, robot});
    }
    case code_id('C', 'S'):
      if (p.field_count == 1) {
        return DecodeError{core::kErrWrongFieldCount, 1,
                           "CS has 1 field; expects 0 or 2 (width_px, height_px)"};
      }
      if (p.field_count == 0) return make<M>(CameraShoot{});
      in_range(p, 0, 1, 8192, &error) && in_range(p, 1, 1, 8192, &error);
      return checked<M>(error, CameraShoot{p.i32(0), p.i32(1)});
    case code_id('S', 'C'): {
      SpawnCube c;
      if (!parse_color_field(p, 0, &c.color)) return bad_value(p, 0, "red, green, blue");
      c.x_m = wire::mm_field_to_m(p, 1);
      c.y_m = wire::mm_field_to_m(p, 2);
      return make<M>(c);
    }
    case code_id('R', 'S'):
      return make<M>(ResetScene{});
    case code_id('O', 'P'):
      return make<M>(QueryObjects{optional_field(p, 0)});
    case code_id('Q', 'S'): {
      const std::int32_t robot = robot_of(p, 0, &error);
      return checked<M>(error, QueryState{robot});
    }
    case code_id('S', 'P'): {
      const std::int32_t robot = robot_of(p, 0, &error);
      return checked<M>(error, Stop{robot});
    }
    default:
      break;
  }
  return DecodeError{core::kErrInternal, 0, "no typed message for code " + code_text(p.code)};
}

Decoded<TcpFromSim> to_message(const Packet& p, TcpFromSim*) {
  using M = TcpFromSim;
  std::optional<DecodeError> error;
  switch (p.code) {
    case code_id('H', 'I'):
      return peer_hello<M>(p);
    case code_id('J', 'A'): {
      in_range(p, 0, 0, 65535, &error);
      const std::int32_t robot = robot_of(p, 2, &error);
      return checked<M>(error, JointApplied{seq_of(p, 0), p.u32(1), robot});
    }
    case code_id('G', 'R'): {
      in_range(p, 0, 0, 1, &error) && in_range(p, 1, -1, 0x7fffffff, &error);
      const std::int32_t robot = robot_of(p, 2, &error);
      return checked<M>(error, GripperState{p.i32(0) == 1, p.i32(1), robot});
    }
    case code_id('O', 'P'): {
      ObjectPose o;
      o.id = p.i32(0);
      if (!parse_color_field(p, 1, &o.color)) return bad_value(p, 1, "red, green, blue");
      o.x_m = wire::mm_field_to_m(p, 2);
      o.y_m = wire::mm_field_to_m(p, 3);
      o.z_m = wire::mm_field_to_m(p, 4);
      o.yaw_rad = wire::deg_field_to_rad(p, 5);
      return make<M>(o);
    }
    case code_id('S', 'T'): {
      in_range(p, 0, 0, 65535, &error) && in_range(p, 6, 0, 1, &error) &&
          in_range(p, 7, -1, 0x7fffffff, &error);
      SimState s;
      s.seq = seq_of(p, 0);
      s.t_us = p.u32(1);
      s.q = joints_of(p, 2);
      s.grip_closed = p.i32(6) == 1;
      s.held_id = p.i32(7);
      if (!error && !parse_mode(p, 8, &s.mode)) return bad_value(p, 8, "mirror, simulate");
      s.robot = robot_of(p, 9, &error);
      return checked<M>(error, s);
    }
    case code_id('J', 'W'): {
      in_range(p, 0, 1, 4, &error);
      const double value = p.i32(0) == 1 ? wire::mm_field_to_m(p, 1) : wire::deg_field_to_rad(p, 1);
      const std::int32_t robot = robot_of(p, 2, &error);
      return checked<M>(error, JointWarning{p.i32(0), value, robot});
    }
    case code_id('A', 'K'):
    case code_id('E', 'R'):
      return ack_or_error<M>(p);
    default:
      break;
  }
  return DecodeError{core::kErrInternal, 0, "no typed message for code " + code_text(p.code)};
}

DecodeError to_error(const core::Event& ev, const core::LinkSpec& link, const Packet& rejected) {
  const std::string link_name = link.delimiter == '=' ? "serial" : "TCP";
  std::string what;
  switch (ev.error) {
    case core::kErrLineTooLong:
      what = "line longer than " + std::to_string(ev.detail) + " bytes on the " + link_name +
             " link; skipped to the next newline";
      return DecodeError{ev.error, ev.detail, what};
    case core::kErrBadCharacter:
      what = "bad character or missing delimiter at byte " + std::to_string(ev.detail) +
             "; packets are CODE" + link.delimiter + "field" + link.delimiter +
             "... with fields of [A-Za-z0-9_.-] or numbers";
      break;
    case core::kErrUnknownCode: {
      what = "unknown code " + code_text(ev.code) + " on the " + link_name + " link; valid:";
      for (std::uint8_t i = 0; i < link.code_count; ++i) {
        what += ' ';
        what += code_text(link.codes[i].code);
      }
      break;
    }
    case core::kErrWrongFieldCount: {
      const core::CodeSpec* spec = core::find_code(link, ev.code);
      what = code_text(ev.code) + " has " + std::to_string(ev.detail) + " fields; expects " +
             std::to_string(spec ? spec->min_fields : 0);
      if (spec && spec->max_fields != spec->min_fields) {
        what += ".." + std::to_string(spec->max_fields);
      }
      break;
    }
    case core::kErrBadNumber: {
      what = code_text(ev.code) + " field " + std::to_string(ev.detail);
      const auto i = static_cast<std::uint8_t>(ev.detail);
      if (ev.detail >= 0 && i < rejected.field_count) {
        what += " is '" + excerpt(rejected.text(i), rejected.field_length[i]) + "'";
      }
      what += ": not a valid number (ASCII decimal, no exponent, inf or nan, within range)";
      break;
    }
    case core::kErrPayloadTooLarge:
      what = "image payload above " + std::to_string(ev.detail) + " bytes; skipped";
      return DecodeError{ev.error, ev.detail, what};
    default:
      what = core::error_name(ev.error);
      break;
  }
  what += " in '" + excerpt(rejected.line, rejected.line_length) + "'";
  return DecodeError{ev.error, ev.detail, what};
}

}  // namespace scaratwin::protocol::detail
