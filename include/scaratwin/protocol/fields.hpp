// How a message struct is laid out on the wire: each packet struct of messages.hpp is one row
// of the protocol's code table. It names its code (`kCode`), the reply that answers it when it
// is a request (`kReply`, docs/protocol.md's "reply" column) and, in `fields()`, its members in
// wire order with their wire unit and the values a receiver accepts. From these rows alone the
// codec builds each link's code table (field counts and kinds, scaratwin/protocol/codec_core.h),
// encodes, decodes with its value checks, and matches replies to requests (replies.hpp); the
// docs test checks docs/protocol.md's tables against them and the firmware's table is generated
// from them. Adding a packet is: its struct here, its handler, its test.
//
// Descriptors are plain data (a member pointer, a name, a range); what each kind of field does
// on the wire is in src/protocol/packet_codec.hpp. Pure: no I/O.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

#include "scaratwin/core/robot_types.hpp"

namespace scaratwin::protocol::field {

// Where a field's wire values stand.
enum Where : std::uint8_t {
  kRequired = 0,
  kOptional = 1,  // trailing and optional: a packet may end before it
  kTcpOnly = 2,   // on the TCP link only: the serial link's table has no such field
};

// A request's answer (docs/protocol.md sections 7 and 8, the "reply" column), beside the two
// rules of every link: an ER answers the oldest request, an AK the request whose code it
// carries.
struct Reply {
  std::string_view code;  // the answer's code
  bool partial = false;   // one of several answers; the final one follows (OP ... then AK,OP)
  bool same_seq = false;  // answers only the request with its sequence number (JA: JD, TJ)
};

// An integer field: 'i' (i32) or 'u' (u32) on the wire; a receiver accepts lo..hi when
// `checked`.
template <class M, class V, char Kind>
struct Int {
  static constexpr std::string_view kKinds = Kind == 'u' ? "u" : "i";
  static constexpr std::uint8_t kWhere = kRequired;
  V M::*member;
  bool checked = false;
  std::int64_t lo = 0;
  std::int64_t hi = 0;
};
template <class M, class V>
constexpr Int<M, V, 'i'> i32(V M::*m) {
  return {m};
}
template <class M, class V>
constexpr Int<M, V, 'i'> i32(V M::*m, std::int64_t lo, std::int64_t hi) {
  return {m, true, lo, hi};
}
template <class M, class V>
constexpr Int<M, V, 'u'> u32(V M::*m) {
  return {m};
}
template <class M, class V>
constexpr Int<M, V, 'u'> u32(V M::*m, std::int64_t lo, std::int64_t hi) {
  return {m, true, lo, hi};
}

// An optional trailing i32 (a ping's token, an AK's value).
template <class M>
struct OptInt {
  static constexpr std::string_view kKinds = "i";
  static constexpr std::uint8_t kWhere = kOptional;
  std::optional<std::int32_t> M::*member;
};
template <class M>
constexpr OptInt<M> opt_i32(std::optional<std::int32_t> M::*m) {
  return {m};
}

// A flag sent as 0 or 1.
template <class M>
struct Flag {
  static constexpr std::string_view kKinds = "i";
  static constexpr std::uint8_t kWhere = kRequired;
  bool M::*member;
};
template <class M>
constexpr Flag<M> flag(bool M::*m) {
  return {m};
}

// An enum sent as its number, lo..hi.
template <class M, class E>
struct IntEnum {
  static constexpr std::string_view kKinds = "i";
  static constexpr std::uint8_t kWhere = kRequired;
  E M::*member;
  std::int64_t lo = 0;
  std::int64_t hi = 0;
};
template <class M, class E>
constexpr IntEnum<M, E> int_enum(E M::*m, std::int64_t lo, std::int64_t hi) {
  return {m, lo, hi};
}

// An enum sent as its name: enumerators 0..count-1, named by name_of.
template <class M, class E>
struct NameEnum {
  static constexpr std::string_view kKinds = "t";
  static constexpr std::uint8_t kWhere = kRequired;
  E M::*member;
  const char* (*name_of)(E);
  int count;
  const char* name;  // the field's name in encode errors
};
template <class M, class E>
constexpr NameEnum<M, E> name_enum(E M::*m, const char* (*name_of)(E), int count,
                                   const char* name) {
  return {m, name_of, count, name};
}

// A text of 1..32 characters of [A-Za-z0-9_.-]; `code`: two upper-case letters (an AK's code).
template <class M>
struct Text {
  static constexpr std::string_view kKinds = "t";
  static constexpr std::uint8_t kWhere = kRequired;
  std::string M::*member;
  const char* name;
  bool code = false;
};
template <class M>
constexpr Text<M> text(std::string M::*m, const char* name) {
  return {m, name};
}
template <class M>
constexpr Text<M> code_text(std::string M::*m, const char* name) {
  return {m, name, true};
}

// The hash of a robot description, 8 lower-case hex digits, optional: empty when absent.
template <class M>
struct Description {
  static constexpr std::string_view kKinds = "t";
  static constexpr std::uint8_t kWhere = kOptional;
  std::string M::*member;
};
template <class M>
constexpr Description<M> description(std::string M::*m) {
  return {m};
}

// A length in metres, sent in mm with 3 decimals.
template <class M>
struct Length {
  static constexpr std::string_view kKinds = "d";
  static constexpr std::uint8_t kWhere = kRequired;
  double M::*member;
  const char* name;
};
template <class M>
constexpr Length<M> length_mm(double M::*m, const char* name) {
  return {m, name};
}

// An angle in radians, sent in degrees with 4 decimals.
template <class M>
struct Angle {
  static constexpr std::string_view kKinds = "d";
  static constexpr std::uint8_t kWhere = kRequired;
  double M::*member;
  const char* name;
};
template <class M>
constexpr Angle<M> angle_deg(double M::*m, const char* name) {
  return {m, name};
}

// The four joints (d1 in m, q2..q4 in rad), sent as d1_mm, q2_deg, q3_deg, q4_deg.
template <class M>
struct Joints {
  static constexpr std::string_view kKinds = "dddd";
  static constexpr std::uint8_t kWhere = kRequired;
  JointVector M::*member;
};
template <class M>
constexpr Joints<M> joints(JointVector M::*m) {
  return {m};
}

// A servo angle in radians, sent in whole centidegrees; a receiver accepts lo..hi cdeg when
// `checked`.
template <class M>
struct Centideg {
  static constexpr std::string_view kKinds = "i";
  static constexpr std::uint8_t kWhere = kRequired;
  double M::*member;
  const char* name;
  bool checked = false;
  std::int64_t lo = 0;
  std::int64_t hi = 0;
};
template <class M>
constexpr Centideg<M> cdeg(double M::*m, const char* name) {
  return {m, name};
}
template <class M>
constexpr Centideg<M> cdeg(double M::*m, const char* name, std::int64_t lo, std::int64_t hi) {
  return {m, name, true, lo, hi};
}
// The same, optional and trailing.
template <class M>
struct OptCentideg {
  static constexpr std::string_view kKinds = "i";
  static constexpr std::uint8_t kWhere = kOptional;
  std::optional<double> M::*member;
  const char* name;
  std::int64_t lo = 0;
  std::int64_t hi = 0;
};
template <class M>
constexpr OptCentideg<M> opt_cdeg(std::optional<double> M::*m, const char* name, std::int64_t lo,
                                  std::int64_t hi) {
  return {m, name, lo, hi};
}

// A duration in seconds, sent in whole ms, lo..hi ms.
template <class M>
struct Millis {
  static constexpr std::string_view kKinds = "i";
  static constexpr std::uint8_t kWhere = kRequired;
  double M::*member;
  const char* name;
  std::int64_t lo = 0;
  std::int64_t hi = 0;
};
template <class M>
constexpr Millis<M> millis(double M::*m, const char* name, std::int64_t lo, std::int64_t hi) {
  return {m, name, lo, hi};
}

// Three motor positions in steps (Z, J2, J3).
template <class M, class V>
struct Steps {
  static constexpr std::string_view kKinds = "iii";
  static constexpr std::uint8_t kWhere = kRequired;
  V M::*member;
};
template <class M, class V>
constexpr Steps<M, V> steps(V M::*m) {
  return {m};
}

// The robot index of a robot-addressed packet (protocol v2, docs/protocol.md section 11.3):
// TCP only, trailing, left out for robot 0 (so robot 0's packets are version 1's).
template <class M>
struct Robot {
  static constexpr std::string_view kKinds = "i";
  static constexpr std::uint8_t kWhere = kOptional | kTcpOnly;
  std::int32_t M::*member;
};
template <class M>
constexpr Robot<M> robot(std::int32_t M::*m) {
  return {m};
}

// Fields whose wire form depends on the rest of the message, each written for its one
// message (src/protocol/encode.cpp, decode.cpp): a hello's role and token and the robot it
// names (TCP only), a jog's
// delta (steps, or centidegrees for the wrist), a joint warning's value (mm for joint 1, else
// degrees), a camera shot's optional size (both or neither), an image's byte count (the PNG
// bytes follow the line).
struct HelloAccess {
  static constexpr std::string_view kKinds = "tt";
  static constexpr std::uint8_t kWhere = kOptional | kTcpOnly;
};
// the robot a controlling hello names (after its description hash, TCP only)
struct HelloRobot {
  static constexpr std::string_view kKinds = "i";
  static constexpr std::uint8_t kWhere = kOptional | kTcpOnly;
};
struct JogDelta {
  static constexpr std::string_view kKinds = "i";
  static constexpr std::uint8_t kWhere = kRequired;
};
struct WarningValue {
  static constexpr std::string_view kKinds = "d";
  static constexpr std::uint8_t kWhere = kRequired;
};
struct ShotSize {
  static constexpr std::string_view kKinds = "ii";
  static constexpr std::uint8_t kWhere = kOptional;
};
struct PayloadSize {
  static constexpr std::string_view kKinds = "i";
  static constexpr std::uint8_t kWhere = kRequired;
  static constexpr bool kPayload = true;
};

}  // namespace scaratwin::protocol::field
