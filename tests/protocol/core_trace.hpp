// Test helper: runs the core decoder over a byte stream cut into given chunks and records
// every event as one line of text, so that runs can be compared and printed.
#pragma once

#include <cstdint>
#include <random>
#include <string>
#include <string_view>
#include <vector>

#include "scaratwin/protocol/codec_core.h"

namespace scaratwin::protocol::test {

// "P JD 17|5000123|120|" for a packet, "E 3 0 XX" for an error (code, detail, code letters),
// "R !" for a real-time byte and "B <bytes>" for a whole payload (chunks merged).
inline std::vector<std::string> core_trace(const core::LinkSpec& link, std::string_view bytes,
                                           const std::vector<std::size_t>& cuts,
                                           std::uint16_t capacity = 0) {
  std::vector<char> buffer(capacity ? capacity : link.max_line);
  core::Decoder decoder(link, buffer.data(), static_cast<std::uint16_t>(buffer.size()));
  std::vector<std::string> out;
  bool in_payload = false;
  std::size_t begin = 0;
  auto run = [&](std::size_t end) {
    const auto* data = reinterpret_cast<const std::uint8_t*>(bytes.data()) + begin;
    std::size_t left = end - begin;
    while (left > 0) {
      core::Event ev{};
      const std::size_t used = decoder.feed(data, left, &ev);
      data += used;
      left -= used;
      if (ev.type != core::kEventPayload) in_payload = false;
      if (ev.type == core::kEventPacket) {
        const core::Packet& p = decoder.packet();
        std::string s = "P ";
        s += static_cast<char>(p.code >> 8);
        s += static_cast<char>(p.code & 0xff);
        s += ' ';
        for (std::uint8_t i = 0; i < p.field_count; ++i) {
          s.append(p.text(i), p.field_length[i]);
          s += '|';
        }
        out.push_back(s);
      } else if (ev.type == core::kEventError) {
        std::string s = "E " + std::to_string(ev.error) + " " + std::to_string(ev.detail);
        if (ev.code != 0) {
          s += ' ';
          s += static_cast<char>(ev.code >> 8);
          s += static_cast<char>(ev.code & 0xff);
        }
        out.push_back(s);
      } else if (ev.type == core::kEventRealtime) {
        out.push_back(std::string("R ") + ev.realtime);
      } else if (ev.type == core::kEventPayload) {
        if (!in_payload) out.push_back("B ");
        out.back().append(reinterpret_cast<const char*>(ev.payload), ev.payload_length);
        in_payload = true;
      }
    }
    begin = end;
  };
  for (std::size_t cut : cuts) {
    if (cut > begin && cut <= bytes.size()) run(cut);
  }
  run(bytes.size());
  return out;
}

inline std::vector<std::string> core_trace(const core::LinkSpec& link, std::string_view bytes) {
  return core_trace(link, bytes, {});
}

// Random cut points (sorted), with chunks of 1..max_chunk bytes.
inline std::vector<std::size_t> random_cuts(std::size_t size, std::mt19937& rng,
                                            std::size_t max_chunk) {
  std::uniform_int_distribution<std::size_t> step(1, max_chunk);
  std::vector<std::size_t> cuts;
  for (std::size_t at = step(rng); at < size; at += step(rng)) cuts.push_back(at);
  return cuts;
}

}  // namespace scaratwin::protocol::test
