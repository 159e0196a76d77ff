// Host codec: typed messages (messages.hpp) to wire bytes and back (docs/protocol.md).
//
// encode() writes one packet in the framing of the message's link (plus the PNG payload for
// an Image); append() adds it to a buffer so one write can carry several packets.
// StreamDecoder<Direction> takes bytes in any chunking and yields, in order, one
// Decoded<Direction> per line: the typed message, or a DecodeError whose code and detail are
// what an ER reply carries. Pure: no I/O, no threads, no clock.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <type_traits>
#include <utility>
#include <variant>
#include <vector>

#include "scaratwin/core/result.hpp"
#include "scaratwin/protocol/codec_core.h"
#include "scaratwin/protocol/messages.hpp"

namespace scaratwin::protocol {

// A line (or payload) the decoder rejected.
struct DecodeError {
  std::int32_t code = core::kErrInternal;  // ErrorCode
  std::int32_t detail = 0;                 // docs/protocol.md section 6
  std::string message;                     // names the bad value and what would be valid

  friend bool operator==(const DecodeError&, const DecodeError&) = default;
};

template <typename Direction>
using Decoded = std::variant<Direction, DecodeError>;

// The framing of a link.
enum class Framing { kSerial, kTcp };

// One packet of `message` in the framing of its direction. Errors (Error::code is
// protocol_error_code(ErrorCode)): kErrBadValue for a value the wire cannot carry (NaN, out of
// range, bad text), kErrPayloadTooLarge for an image above 8 MiB, kErrLineTooLong.
Result<std::string> encode(const SerialToDevice& message);
Result<std::string> encode(const SerialFromDevice& message);
Result<std::string> encode(const TcpToSim& message);
Result<std::string> encode(const TcpFromSim& message);

// Appends the packet to `out` (several packets in one write); `out` is unchanged on error.
Status append(std::string& out, const SerialToDevice& message);
Status append(std::string& out, const SerialFromDevice& message);
Status append(std::string& out, const TcpToSim& message);
Status append(std::string& out, const TcpFromSim& message);

// encode(message, framing) for a single message struct: Stop{} on kSerial is the serial SP,
// on kTcp the TCP SP. A struct that has no code on that link gives kErrUnknownCode.
template <typename Message>
Result<std::string> encode(const Message& message, Framing framing);

namespace detail {

template <typename T, typename Variant>
struct IsAlternative;
template <typename T, typename... Ts>
struct IsAlternative<T, std::variant<Ts...>> : std::disjunction<std::is_same<T, Ts>...> {};
template <typename T, typename Variant>
inline constexpr bool kIsAlternative = IsAlternative<T, Variant>::value;

// Link direction of each variant (the receiver's code table).
template <typename Direction>
const core::LinkSpec& link_of();
template <>
inline const core::LinkSpec& link_of<SerialToDevice>() {
  return core::kSerialHostToDevice;
}
template <>
inline const core::LinkSpec& link_of<SerialFromDevice>() {
  return core::kSerialDeviceToHost;
}
template <>
inline const core::LinkSpec& link_of<TcpToSim>() {
  return core::kTcpHubToSim;
}
template <>
inline const core::LinkSpec& link_of<TcpFromSim>() {
  return core::kTcpSimToHub;
}

// Packet -> typed message, with the per-code value checks (kErrBadValue).
Decoded<SerialToDevice> to_message(const core::Packet& p, SerialToDevice* tag);
Decoded<SerialFromDevice> to_message(const core::Packet& p, SerialFromDevice* tag);
Decoded<TcpToSim> to_message(const core::Packet& p, TcpToSim* tag);
Decoded<TcpFromSim> to_message(const core::Packet& p, TcpFromSim* tag);
// Core error event -> DecodeError with a message.
// `rejected` is the decoder's packet view, which describes the rejected line.
DecodeError to_error(const core::Event& event, const core::LinkSpec& link,
                     const core::Packet& rejected);

}  // namespace detail

template <typename Message>
Result<std::string> encode(const Message& message, Framing framing) {
  constexpr bool serial_to = detail::kIsAlternative<Message, SerialToDevice>;
  constexpr bool serial_from = detail::kIsAlternative<Message, SerialFromDevice>;
  constexpr bool tcp_to = detail::kIsAlternative<Message, TcpToSim>;
  constexpr bool tcp_from = detail::kIsAlternative<Message, TcpFromSim>;
  static_assert(serial_to || serial_from || tcp_to || tcp_from, "not a protocol message");
  if (framing == Framing::kSerial) {
    if constexpr (serial_to) return encode(SerialToDevice(message));
    if constexpr (serial_from) return encode(SerialFromDevice(message));
  } else {
    if constexpr (tcp_to) return encode(TcpToSim(message));
    if constexpr (tcp_from) return encode(TcpFromSim(message));
  }
  return Error{protocol_error_code(core::kErrUnknownCode),
               "encode: this message has no code on the " +
                   std::string(framing == Framing::kSerial ? "serial" : "TCP") + " link"};
}

// Streaming decoder for one direction: SerialToDevice (what the firmware or its emulator
// receives), SerialFromDevice (the hub, from the robot), TcpToSim (the simulator),
// TcpFromSim (the hub, from the simulator).
template <typename Direction>
class StreamDecoder {
 public:
  StreamDecoder()
      : line_(detail::link_of<Direction>().max_line),
        decoder_(detail::link_of<Direction>(), line_.data(),
                 static_cast<std::uint16_t>(line_.size())) {}
  StreamDecoder(const StreamDecoder&) = delete;
  StreamDecoder& operator=(const StreamDecoder&) = delete;

  // Decodes `bytes` (any chunk of the stream) and calls sink(Decoded<Direction>&&) for each
  // complete line, real-time byte or image, in stream order.
  template <typename Sink>
  void feed(std::string_view bytes, Sink&& sink) {
    const auto* data = reinterpret_cast<const std::uint8_t*>(bytes.data());
    std::size_t left = bytes.size();
    while (left > 0) {
      core::Event ev{};
      const std::size_t used = decoder_.feed(data, left, &ev);
      data += used;
      left -= used;
      switch (ev.type) {
        case core::kEventPacket:
          on_packet(sink);
          break;
        case core::kEventError:
          sink(Decoded<Direction>(
              detail::to_error(ev, detail::link_of<Direction>(), decoder_.packet())));
          break;
        case core::kEventRealtime:
          if constexpr (std::is_same_v<Direction, SerialToDevice>) {
            sink(
                Decoded<Direction>(Direction(RealtimeCommand{static_cast<Realtime>(ev.realtime)})));
          }
          break;
        case core::kEventPayload:
          if constexpr (std::is_same_v<Direction, TcpFromSim>) {
            image_.png.insert(image_.png.end(), ev.payload, ev.payload + ev.payload_length);
            if (ev.payload_left == 0) emit_image(sink);
          }
          break;
        default:
          break;
      }
    }
  }

  // Convenience: everything `bytes` completes, as a vector.
  std::vector<Decoded<Direction>> feed(std::string_view bytes) {
    std::vector<Decoded<Direction>> out;
    feed(bytes, [&out](Decoded<Direction>&& d) { out.push_back(std::move(d)); });
    return out;
  }

  // Drops a partial line or image (after a reconnect).
  void reset() {
    decoder_.reset();
    image_.png.clear();
  }

 private:
  template <typename Sink>
  void on_packet(Sink& sink) {
    const core::Packet& p = decoder_.packet();
    if constexpr (std::is_same_v<Direction, TcpFromSim>) {
      if (p.code == core::code_id('I', 'M')) {
        image_.png.clear();
        image_.png.reserve(static_cast<std::size_t>(p.i32(0)));
        if (decoder_.payload_left() == 0) emit_image(sink);
        return;
      }
    }
    sink(detail::to_message(p, static_cast<Direction*>(nullptr)));
  }

  template <typename Sink>
  void emit_image(Sink& sink) {
    Image done;
    done.png.swap(image_.png);
    sink(Decoded<Direction>(Direction(std::move(done))));
  }

  std::vector<char> line_;
  core::Decoder decoder_;
  Image image_;
};

using SerialToDeviceDecoder = StreamDecoder<SerialToDevice>;
using SerialFromDeviceDecoder = StreamDecoder<SerialFromDevice>;
using TcpToSimDecoder = StreamDecoder<TcpToSim>;
using TcpFromSimDecoder = StreamDecoder<TcpFromSim>;

}  // namespace scaratwin::protocol
