// The code table of each link direction, derived from the packet structs' rows (messages.hpp,
// fields.hpp): a direction's codes are its variant's packet types in order, each with the
// field count range and the field kinds of its fields on that link. Compile-time only.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <string_view>
#include <tuple>
#include <type_traits>
#include <variant>

#include "scaratwin/protocol/codec_core.h"
#include "scaratwin/protocol/messages.hpp"

namespace scaratwin::protocol::table {

// A struct with a row in the code table (RealtimeCommand is a byte, not a packet).
template <class T>
concept Packet = requires {
  T::kCode;
  T::fields();
};

// A request that a reply answers (a "reply" cell in docs/protocol.md).
template <class T>
concept Request = Packet<T> && requires {
  T::kReply;
};

// A field whose count is the length of a binary payload that follows the line.
template <class F>
concept PayloadField = requires {
  F::kPayload;
};

template <class T>
constexpr std::uint16_t code_of() {
  static_assert(T::kCode.size() == 2, "a packet code is two letters");
  return core::code_id(T::kCode[0], T::kCode[1]);
}

// The row of packet T on the TCP link (`tcp`) or the serial link.
template <Packet T>
constexpr core::CodeSpec code_spec(bool tcp) {
  char kinds[core::kMaxFields + 1] = {};
  std::size_t n = 0;
  std::size_t min = core::kMaxFields + 1;  // the first optional wire field
  std::uint8_t flags = 0;
  std::apply(
      [&](const auto&... f) {
        [[maybe_unused]] const auto add = [&](const auto& one) {
          using F = std::decay_t<decltype(one)>;
          if (!tcp && (F::kWhere & field::kTcpOnly)) return;
          if ((F::kWhere & field::kOptional) && min > n) min = n;
          if constexpr (PayloadField<F>) flags |= core::kCodeHasPayload;
          for (char k : F::kKinds) kinds[n++] = k;
        };
        (add(f), ...);
      },
      T::fields());
  if (min > n) min = n;
  return core::make_code(T::kCode[0], T::kCode[1], static_cast<std::uint8_t>(min), kinds, flags);
}

// Every packet's row of a direction, in the variant's order.
template <class Direction>
struct Rows;
template <class... Ts>
struct Rows<std::variant<Ts...>> {
  static constexpr std::size_t kCount = (0 + ... + (Packet<Ts> ? 1 : 0));

  static constexpr std::array<core::CodeSpec, kCount> make(bool tcp) {
    std::array<core::CodeSpec, kCount> out{};
    std::size_t i = 0;
    const auto add = [&]<class T>(T*) {
      if constexpr (Packet<T>) out[i++] = code_spec<T>(tcp);
    };
    (add(static_cast<Ts*>(nullptr)), ...);
    return out;
  }
};

// Whether a direction is on the TCP link (else serial).
template <class Direction>
constexpr bool kTcp = std::is_same_v<Direction, TcpToSim> || std::is_same_v<Direction, TcpFromSim>;

}  // namespace scaratwin::protocol::table
