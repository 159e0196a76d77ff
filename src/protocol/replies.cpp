// Which packet answers which request: see scaratwin/protocol/replies.hpp.
#include "scaratwin/protocol/replies.hpp"

#include <array>
#include <cstddef>
#include <type_traits>
#include <variant>

#include "packet_table.hpp"

namespace scaratwin::protocol {
namespace {

// The reply rows of a direction's requests (their `kReply`), in the variant's order.
template <class Direction>
struct RuleRows;
template <class... Ts>
struct RuleRows<std::variant<Ts...>> {
  static constexpr std::size_t kCount = (0 + ... + (table::Request<Ts> ? 1 : 0));
  static constexpr std::array<ReplyRule, kCount> make() {
    std::array<ReplyRule, kCount> out{};
    std::size_t i = 0;
    const auto add = [&]<class T>(T*) {
      if constexpr (table::Request<T>) {
        out[i++] = ReplyRule{T::kCode, T::kReply.code, T::kReply.partial, T::kReply.same_seq};
      }
    };
    (add(static_cast<Ts*>(nullptr)), ...);
    return out;
  }
};

constexpr auto kTcpRules = RuleRows<TcpToSim>::make();
constexpr auto kSerialRules = RuleRows<SerialToDevice>::make();

template <typename Variant>
std::string_view code_of_variant(const Variant& message) {
  return std::visit(
      [](const auto& m) -> std::string_view {
        using T = std::decay_t<decltype(m)>;
        static_assert(table::Packet<T>, "a received message type without its row");
        return T::kCode;
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
