// Packet -> typed message for the four link directions, each packet read by its row
// (messages.hpp, fields.hpp) with the value checks it names, and the messages of decode errors.
#include <string>
#include <tuple>
#include <type_traits>
#include <utility>
#include <variant>

#include "packet_table.hpp"
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

bool is_code_text(const Packet& p, std::uint8_t i) {
  const char* s = p.text(i);
  return p.field_length[i] == 2 && s[0] >= 'A' && s[0] <= 'Z' && s[1] >= 'A' && s[1] <= 'Z';
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

// Reads one packet's fields in order. The first value a receiver refuses is the packet's
// error; the fields after it are read but not checked.
struct Reader {
  const Packet& p;
  bool tcp;
  std::uint8_t i = 0;  // the next wire field
  std::optional<DecodeError> error;

  // Whether the field at the current index is there (an optional one may not be).
  template <class F>
  bool present() const {
    if (!tcp && (F::kWhere & field::kTcpOnly)) return false;
    return !(F::kWhere & field::kOptional) || i < p.field_count;
  }
  // Range check of integer field `k`.
  void check(std::uint8_t k, std::int64_t lo, std::int64_t hi) {
    if (!error) in_range(p, k, lo, hi, &error);
  }
  void refuse(std::uint8_t k, const std::string& valid) {
    if (!error) error = bad_value(p, k, valid);
  }
};

// One get() per kind of field (fields.hpp), each reading its member from wire field r.i.
template <class M, class V, char K>
void get(Reader& r, M& m, const field::Int<M, V, K>& f) {
  if (f.checked) r.check(r.i, f.lo, f.hi);
  if constexpr (K == 'u') {
    m.*f.member = static_cast<V>(r.p.u32(r.i));
  } else {
    m.*f.member = static_cast<V>(r.p.i32(r.i));
  }
}
template <class M>
void get(Reader& r, M& m, const field::OptInt<M>& f) {
  m.*f.member = r.p.i32(r.i);
}
template <class M>
void get(Reader& r, M& m, const field::Flag<M>& f) {
  r.check(r.i, 0, 1);
  m.*f.member = r.p.i32(r.i) == 1;
}
template <class M, class E>
void get(Reader& r, M& m, const field::IntEnum<M, E>& f) {
  r.check(r.i, f.lo, f.hi);
  m.*f.member = static_cast<E>(r.p.i32(r.i));
}
template <class M, class E>
void get(Reader& r, M& m, const field::NameEnum<M, E>& f) {
  std::string valid;
  for (int k = 0; k < f.count; ++k) {
    const E e = static_cast<E>(k);
    if (r.p.text_equals(r.i, f.name_of(e))) {
      m.*f.member = e;
      return;
    }
    valid += (k ? ", " : "") + std::string(f.name_of(e));
  }
  r.refuse(r.i, valid);
}
template <class M>
void get(Reader& r, M& m, const field::Text<M>& f) {
  if (f.code && !is_code_text(r.p, r.i)) r.refuse(r.i, "a two-letter upper-case code");
  m.*f.member = field_text(r.p, r.i);
}
template <class M>
void get(Reader& r, M& m, const field::Description<M>& f) {
  if (!is_description(r.p, r.i)) {
    r.refuse(r.i, "a description hash of 8 lower-case hex digits");
    return;
  }
  m.*f.member = field_text(r.p, r.i);
}
template <class M>
void get(Reader& r, M& m, const field::Length<M>& f) {
  m.*f.member = wire::mm_field_to_m(r.p, r.i);
}
template <class M>
void get(Reader& r, M& m, const field::Angle<M>& f) {
  m.*f.member = wire::deg_field_to_rad(r.p, r.i);
}
template <class M>
void get(Reader& r, M& m, const field::Joints<M>& f) {
  const std::uint8_t k = r.i;
  m.*f.member = JointVector{wire::mm_field_to_m(r.p, k), wire::deg_field_to_rad(r.p, k + 1),
                            wire::deg_field_to_rad(r.p, k + 2), wire::deg_field_to_rad(r.p, k + 3)};
}
template <class M>
void get(Reader& r, M& m, const field::Centideg<M>& f) {
  if (f.checked) r.check(r.i, f.lo, f.hi);
  m.*f.member = wire::cdeg_to_rad(r.p.i32(r.i));
}
template <class M>
void get(Reader& r, M& m, const field::OptCentideg<M>& f) {
  r.check(r.i, f.lo, f.hi);
  m.*f.member = wire::cdeg_to_rad(r.p.i32(r.i));
}
template <class M>
void get(Reader& r, M& m, const field::Millis<M>& f) {
  r.check(r.i, f.lo, f.hi);
  m.*f.member = wire::ms_to_s(r.p.i32(r.i));
}
template <class M, class V>
void get(Reader& r, M& m, const field::Steps<M, V>& f) {
  m.*f.member = {r.p.i32(r.i), r.p.i32(r.i + 1), r.p.i32(r.i + 2)};
}
template <class M>
void get(Reader& r, M& m, const field::Robot<M>& f) {
  r.check(r.i, 0, core::kMaxRobotIndex);
  m.*f.member = r.p.i32(r.i);
}
// the role (control or observe) and the token ("-": none) of a hello on TCP
void get(Reader& r, Hello& m, const field::HelloAccess&) {
  if (!r.p.text_equals(r.i, "control") && !r.p.text_equals(r.i, "observe")) {
    r.refuse(r.i, "control or observe");
  }
  m.role = field_text(r.p, r.i);
  if (r.i + 1 < r.p.field_count && !r.p.text_equals(r.i + 1, "-")) {
    m.token = field_text(r.p, r.i + 1);
  }
}
void get(Reader& r, Hello& m, const field::HelloRobot&) {
  r.check(r.i, 0, core::kMaxRobotIndex);
  m.robot = r.p.i32(r.i);
}
void get(Reader& r, Jog& m, const field::JogDelta&) {
  const std::int32_t v = r.p.i32(r.i);
  m.delta = m.axis == Axis::kWrist ? wire::cdeg_to_rad(v) : v;
}
void get(Reader& r, JointWarning& m, const field::WarningValue&) {
  m.value = m.joint == 1 ? wire::mm_field_to_m(r.p, r.i) : wire::deg_field_to_rad(r.p, r.i);
}
// a camera shot's size: both fields or neither
void get(Reader& r, CameraShoot& m, const field::ShotSize&) {
  if (r.p.field_count == r.i + 1) {
    if (!r.error) {
      r.error = DecodeError{core::kErrWrongFieldCount, r.p.field_count,
                            "CS has 1 field; expects 0 or 2 (width_px, height_px)"};
    }
    return;
  }
  r.check(r.i, 1, 8192);
  r.check(r.i + 1, 1, 8192);
  m.width_px = r.p.i32(r.i);
  m.height_px = r.p.i32(r.i + 1);
}
// the PNG bytes follow the line: the stream decoder collects them (codec.hpp)
void get(Reader&, Image&, const field::PayloadSize&) {}

// A packet of type M from its fields, in their row's order.
template <typename Direction, class M>
Decoded<Direction> get_packet(const Packet& p) {
  Reader r{p, table::kTcp<Direction>, 0, std::nullopt};
  Decoded<Direction> out(std::in_place_index<0>, std::in_place_type<M>);
  M& m = std::get<M>(std::get<0>(out));
  std::apply(
      [&](const auto&... f) {
        [[maybe_unused]] const auto one = [&](const auto& descriptor) {
          using F = std::decay_t<decltype(descriptor)>;
          if (!r.template present<F>()) return;
          get(r, m, descriptor);
          r.i = static_cast<std::uint8_t>(r.i + F::kKinds.size());
        };
        (one(f), ...);
      },
      M::fields());
  if (r.error) return Decoded<Direction>(std::in_place_index<1>, std::move(*r.error));
  return out;
}

// The packet type of the direction whose code the packet has.
template <typename Direction, class T, class... Rest>
Decoded<Direction> decode_as(const Packet& p) {
  if constexpr (table::Packet<T>) {
    if (p.code == table::code_of<T>()) return get_packet<Direction, T>(p);
  }
  if constexpr (sizeof...(Rest) > 0) {
    return decode_as<Direction, Rest...>(p);
  } else {
    return DecodeError{core::kErrInternal, 0, "no typed message for code " + code_text(p.code)};
  }
}

template <typename Direction>
struct Dispatch;
template <typename... Ts>
struct Dispatch<std::variant<Ts...>> {
  static Decoded<std::variant<Ts...>> decode(const Packet& p) {
    return decode_as<std::variant<Ts...>, Ts...>(p);
  }
};

}  // namespace

Decoded<SerialToDevice> to_message(const Packet& p, SerialToDevice*) {
  return Dispatch<SerialToDevice>::decode(p);
}
Decoded<SerialFromDevice> to_message(const Packet& p, SerialFromDevice*) {
  return Dispatch<SerialFromDevice>::decode(p);
}
Decoded<TcpToSim> to_message(const Packet& p, TcpToSim*) { return Dispatch<TcpToSim>::decode(p); }
Decoded<TcpFromSim> to_message(const Packet& p, TcpFromSim*) {
  return Dispatch<TcpFromSim>::decode(p);
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
