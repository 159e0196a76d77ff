// Which packet answers which request: see scaratwin/protocol/replies.hpp.
#include "scaratwin/protocol/replies.hpp"

#include <type_traits>
#include <variant>

namespace scaratwin::protocol {
namespace {

constexpr ReplyRule kTcpRules[] = {
    {"HI", "HI"},
    {"JD", "JA", false, true},
    {"TJ", "JA", false, true},
    {"GR", "GR"},
    {"CS", "IM"},
    {"OP", "OP", true},
    {"QS", "ST"},
};

constexpr ReplyRule kSerialRules[] = {
    {"HI", "HI"},
    {"QS", "ST"},
};

template <typename T>
constexpr std::string_view code_of_type() {
  if constexpr (std::is_same_v<T, PeerHello>) {
    return "HI";
  } else if constexpr (std::is_same_v<T, JointApplied>) {
    return "JA";
  } else if constexpr (std::is_same_v<T, GripperState>) {
    return "GR";
  } else if constexpr (std::is_same_v<T, Image>) {
    return "IM";
  } else if constexpr (std::is_same_v<T, ObjectPose>) {
    return "OP";
  } else if constexpr (std::is_same_v<T, SimState> || std::is_same_v<T, DeviceState>) {
    return "ST";
  } else if constexpr (std::is_same_v<T, JointWarning>) {
    return "JW";
  } else if constexpr (std::is_same_v<T, DeviceEvent>) {
    return "EV";
  } else if constexpr (std::is_same_v<T, Ack>) {
    return "AK";
  } else if constexpr (std::is_same_v<T, ErrorReply>) {
    return "ER";
  } else {
    return {};
  }
}

template <typename Variant>
std::string_view code_of_variant(const Variant& message) {
  return std::visit(
      [](const auto& m) -> std::string_view {
        using T = std::decay_t<decltype(m)>;
        constexpr std::string_view code = code_of_type<T>();
        static_assert(code.size() == 2, "a received message type without its code");
        return code;
      },
      message);
}

// The sequence number of the JD or TJ that a JA answers.
template <typename Variant>
std::optional<std::uint16_t> applied_seq(const Variant& message) {
  return std::visit(
      [](const auto& m) -> std::optional<std::uint16_t> {
        if constexpr (std::is_same_v<std::decay_t<decltype(m)>, JointApplied>) return m.seq;
        return std::nullopt;
      },
      message);
}

template <typename Variant>
ReplyMatch match(std::span<const ReplyRule> rules, std::string_view request,
                 std::optional<std::uint16_t> seq, const Variant& message) {
  if (std::holds_alternative<ErrorReply>(message)) return ReplyMatch::kFinal;
  if (const auto* ak = std::get_if<Ack>(&message)) {
    return ak->code == request ? ReplyMatch::kFinal : ReplyMatch::kNo;
  }
  const std::string_view reply = code_of_variant(message);
  for (const ReplyRule& r : rules) {
    if (r.request != request || r.reply != reply) continue;
    if (r.same_seq && (!seq || applied_seq(message) != seq)) return ReplyMatch::kNo;
    return r.partial ? ReplyMatch::kPartial : ReplyMatch::kFinal;
  }
  return ReplyMatch::kNo;
}

}  // namespace

std::span<const ReplyRule> tcp_reply_rules() { return kTcpRules; }
std::span<const ReplyRule> serial_reply_rules() { return kSerialRules; }

std::string_view code_of(const TcpFromSim& message) { return code_of_variant(message); }
std::string_view code_of(const SerialFromDevice& message) { return code_of_variant(message); }

ReplyMatch reply_match(std::string_view request, std::optional<std::uint16_t> seq,
                       const TcpFromSim& message) {
  return match(tcp_reply_rules(), request, seq, message);
}
ReplyMatch reply_match(std::string_view request, std::optional<std::uint16_t> seq,
                       const SerialFromDevice& message) {
  return match(serial_reply_rules(), request, seq, message);
}

}  // namespace scaratwin::protocol
