// Invariants checked on arbitrary input by the protocol fuzzers (fuzz/fuzz_*.cpp) and by the
// GoogleTest that replays their saved corpus (tests/protocol/test_fuzz_corpus.cpp). Each check
// returns an empty string when the invariants hold, or a description of the violation.
//
// core decoder: the events of the input fed at once equal the events of the same input fed
// in chunks (chunk size from the input), and every packet matches its code table.
// typed decoders: every decoded message re-encodes; decoding that encoding gives exactly one
// message whose encoding is the same bytes (the wire form is a fixed point after one round).
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "scaratwin/protocol/codec.hpp"
#include "scaratwin/protocol/codec_core.h"

namespace scaratwin::protocol::fuzz {

inline const core::LinkSpec& link_by_index(unsigned i) {
  static const core::LinkSpec* const kLinks[] = {&core::kSerialHostToDevice,
                                                 &core::kSerialDeviceToHost, &core::kTcpHubToSim,
                                                 &core::kTcpSimToHub};
  return *kLinks[i % 4];
}

// One event as bytes, payload chunks merged, for comparing runs.
inline std::vector<std::string> core_events(const core::LinkSpec& link, const std::uint8_t* data,
                                            std::size_t size, std::size_t chunk,
                                            std::string* violation) {
  std::vector<char> line(link.max_line);
  core::Decoder decoder(link, line.data(), static_cast<std::uint16_t>(line.size()));
  std::vector<std::string> events;
  bool in_payload = false;
  for (std::size_t at = 0; at < size;) {
    const std::size_t end = size - at < chunk ? size : at + chunk;
    while (at < end) {
      core::Event ev{};
      const std::size_t used = decoder.feed(data + at, end - at, &ev);
      if (used == 0 || used > end - at) {
        *violation = "feed consumed " + std::to_string(used) + " of " + std::to_string(end - at);
        return events;
      }
      at += used;
      if (ev.type == core::kEventPayload) {
        if (!in_payload) events.emplace_back("B");
        events.back().append(reinterpret_cast<const char*>(ev.payload), ev.payload_length);
        in_payload = ev.payload_left != 0;
        continue;
      }
      in_payload = false;
      if (ev.type == core::kEventPacket) {
        const core::Packet& p = decoder.packet();
        const core::CodeSpec* spec = core::find_code(link, p.code);
        if (spec != p.spec || p.field_count < spec->min_fields ||
            p.field_count > spec->max_fields) {
          *violation = "packet does not match its code table";
        }
        events.emplace_back("P");
        events.back().append(p.line, p.line_length);
      } else if (ev.type == core::kEventError) {
        if (ev.error < core::kErrLineTooLong || ev.error > core::kErrPayloadTooLarge) {
          *violation = "decode error outside 1..12: " + std::to_string(ev.error);
        }
        events.push_back("E" + std::to_string(ev.error) + "/" + std::to_string(ev.detail));
      } else if (ev.type == core::kEventRealtime) {
        events.push_back(std::string("R") + ev.realtime);
      }
    }
  }
  return events;
}

// Input: byte 0 picks the link, byte 1 the chunk size, the rest is the stream.
inline std::string check_core(const std::uint8_t* data, std::size_t size) {
  if (size < 2) return {};
  const core::LinkSpec& link = link_by_index(data[0]);
  const std::size_t chunk = 1 + data[1] % 64;
  std::string violation;
  const auto whole = core_events(link, data + 2, size - 2, size, &violation);
  const auto chunked = core_events(link, data + 2, size - 2, chunk, &violation);
  if (!violation.empty()) return violation;
  if (whole != chunked) return "chunked decoding differs (chunk " + std::to_string(chunk) + ")";
  return {};
}

// Input: the stream for one typed decoder.
template <typename Direction>
std::string check_typed(const std::uint8_t* data, std::size_t size) {
  StreamDecoder<Direction> decoder;
  std::string violation;
  decoder.feed(std::string_view(reinterpret_cast<const char*>(data), size),
               [&](Decoded<Direction>&& item) {
                 if (!violation.empty()) return;
                 if (item.index() == 1) {
                   const auto& e = std::get<1>(item);
                   if (e.code < core::kErrLineTooLong || e.code > core::kErrPayloadTooLarge ||
                       e.message.empty()) {
                     violation = "bad decode error " + std::to_string(e.code) + ": " + e.message;
                   }
                   return;
                 }
                 const auto first = encode(std::get<0>(item));
                 if (!first.ok()) {
                   // values that decode but exceed what the encoder writes (|mm| >= 2.1e6).
                   if (first.error().code != protocol_error_code(core::kErrBadValue)) {
                     violation = "decoded message does not encode: " + first.error().message;
                   }
                   return;
                 }
                 StreamDecoder<Direction> again;
                 const auto items = again.feed(*first);
                 if (items.size() != 1 || items[0].index() != 0) {
                   violation = "re-encoded message does not decode: " + *first;
                   return;
                 }
                 const auto second = encode(std::get<0>(items[0]));
                 if (!second.ok() || *second != *first) {
                   violation = "encoding is not stable: " + *first;
                 }
               });
  return violation;
}

}  // namespace scaratwin::protocol::fuzz
