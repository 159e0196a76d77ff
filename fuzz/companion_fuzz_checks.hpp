// The invariants the companion dialect's fuzzer checks on every input (fuzz_companion.cpp),
// shared with the replay of the saved corpus in the normal tests
// (tests/sim/test_companion_fuzz_corpus.cpp). docs/protocol.md section 13 is the dialect.
//
// The input is a byte stream from a client, as the server reads it.
// - Framing: the frames and the refused length bytes do not depend on how the stream is cut
//   into reads (whole, byte by byte, and cut at a point the input chooses); every byte is
//   accounted for (a frame's length byte and payload, a refused zero length byte, or the held
//   bytes of the frame still incomplete); a frame holds 1..255 bytes.
// - Decoding, checked against an oracle written from the docs, not from the decoder: a number
//   is `[+-]? digits [. digits] [(e|E) [+-]? digits]` with a digit before the exponent, read
//   with strtod; a frame is accepted exactly when it is printable ASCII, names a known command
//   with the right number of fields, and every field is valid (numbers within the joint
//   limits); an accepted command carries what the frame said; a refusal has a message.
#pragma once

#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <string>
#include <string_view>
#include <vector>

#include "scaratwin/core/units.hpp"
#include "scaratwin/kinematics/robot_model.hpp"
#include "scaratwin/sim/companion.hpp"

namespace scaratwin::fuzz {

namespace companion_detail {

struct Cut {
  std::vector<std::string> frames;
  int zero_length_bytes = 0;
  std::size_t pending = 0;
};

inline Cut cut(std::string_view bytes, std::size_t chunk) {
  sim::CompanionFramer framer;
  Cut out;
  for (std::size_t at = 0; at < bytes.size(); at += chunk) {
    framer.feed(
        bytes.substr(at, chunk), [&](std::string_view f) { out.frames.emplace_back(f); },
        [&](const std::string&) { ++out.zero_length_bytes; });
  }
  out.pending = framer.pending();
  return out;
}

inline bool digit(char c) { return c >= '0' && c <= '9'; }

// The docs' number grammar, then strtod (not the decoder's from_chars) for the value.
inline bool number(std::string_view t, double& value) {
  std::size_t k = 0;
  if (k < t.size() && (t[k] == '+' || t[k] == '-')) ++k;
  std::size_t digits = 0;
  while (k < t.size() && digit(t[k])) ++k, ++digits;
  if (k < t.size() && t[k] == '.') {
    ++k;
    while (k < t.size() && digit(t[k])) ++k, ++digits;
  }
  if (digits == 0) return false;
  if (k < t.size() && (t[k] == 'e' || t[k] == 'E')) {
    ++k;
    if (k < t.size() && (t[k] == '+' || t[k] == '-')) ++k;
    std::size_t exp_digits = 0;
    while (k < t.size() && digit(t[k])) ++k, ++exp_digits;
    if (exp_digits == 0) return false;
  }
  if (k != t.size()) return false;
  const std::string s(t);
  value = std::strtod(s.c_str(), nullptr);
  return std::isfinite(value);
}

inline std::vector<std::string_view> fields(std::string_view args) {
  std::vector<std::string_view> out;
  for (std::size_t start = 0;;) {
    const std::size_t comma = args.find(',', start);
    out.push_back(args.substr(start, comma == std::string_view::npos ? comma : comma - start));
    if (comma == std::string_view::npos) return out;
    start = comma + 1;
  }
}

inline bool close(double a, double b) {
  return std::abs(a - b) <= 1e-12 * std::max(1.0, std::abs(b));
}

// What the oracle expects of one frame: empty when its verdict and the decoder's agree.
inline std::string check_frame(std::string_view payload, const RobotModel& robot) {
  const auto got = sim::parse_companion(payload, robot);
  const std::string shown = "'" + std::string(payload.substr(0, 60)) + "'";
  bool printable = true;
  for (const char c : payload) {
    const auto u = static_cast<unsigned char>(c);
    if (u < 0x20 || u > 0x7e) printable = false;
  }
  const std::size_t colon = payload.find(':');
  // the oracle's verdict: accepted (and what it carries) or refused
  bool accept = false;
  if (printable && colon != std::string_view::npos) {
    const std::string_view cmd = payload.substr(0, colon);
    const auto f = fields(payload.substr(colon + 1));
    using Kind = sim::CompanionCommand::Kind;
    if (cmd == "Name") {
      accept = f.size() == 1;
      if (accept && got && (got->kind != Kind::kName || got->name != f[0])) {
        return shown + ": Name carries another name";
      }
    } else if (cmd == "ModGrab") {
      accept = f.size() == 1 && (f[0] == "0" || f[0] == "1");
      if (accept && got && (got->kind != Kind::kModGrab || got->grab != (f[0] == "1"))) {
        return shown + ": ModGrab carries another grasp";
      }
    } else if (cmd == "NewObj") {
      accept = f.size() == 1 && (f[0] == "1" || f[0] == "2" || f[0] == "3");
      if (accept && got &&
          (got->kind != Kind::kNewObj || static_cast<int>(got->color) != f[0][0] - '1')) {
        return shown + ": NewObj carries another colour";
      }
    } else if (cmd == "Camera") {
      accept = f.size() == 3 && !f[0].empty();
      if (accept && got &&
          (got->kind != Kind::kCamera || got->camera != f[0] || got->path != f[1] ||
           got->file != f[2])) {
        return shown + ": Camera carries other fields";
      }
    } else if (cmd == "ModRobot") {
      // at least four fields; the first four are d1 (m) and q2..q4 (deg) within the limits
      accept = f.size() >= 4;
      double v[4] = {};
      for (int j = 0; accept && j < 4; ++j) {
        accept = number(f[static_cast<std::size_t>(j)], v[j]);
        if (!accept) break;
        const JointLimit& lim = robot.limits[static_cast<std::size_t>(j)];
        const double lo = j == 0 ? lim.min : rad_to_deg(lim.min);
        const double hi = j == 0 ? lim.max : rad_to_deg(lim.max);
        const double slack = j == 0 ? 1e-12 : 1e-9;
        accept = v[j] >= lo - slack && v[j] <= hi + slack;
      }
      if (accept && got) {
        if (got->kind != Kind::kModRobot) return shown + ": ModRobot decoded as another command";
        for (int j = 0; j < 4; ++j) {
          const JointLimit& lim = robot.limits[static_cast<std::size_t>(j)];
          const double want = j == 0 ? v[0] : deg_to_rad(v[j]);
          const double q = got->q[static_cast<std::size_t>(j)];
          if (!std::isfinite(q) || q < lim.min || q > lim.max) {
            return shown + ": joint " + std::to_string(j + 1) + " outside its limits";
          }
          if (!close(q, std::min(std::max(want, lim.min), lim.max))) {
            return shown + ": joint " + std::to_string(j + 1) + " is " + std::to_string(q) +
                   ", the frame says " + std::to_string(want);
          }
        }
      }
    }
  }
  if (accept && !got) return shown + " refused (" + got.error().message + "), the docs accept it";
  if (!accept && got) return shown + " accepted, the docs refuse it";
  if (!got && got.error().message.empty()) return shown + " refused without a message";
  return {};
}

}  // namespace companion_detail

inline std::string check_companion(const std::uint8_t* data, std::size_t size,
                                   const RobotModel& robot) {
  using namespace companion_detail;
  const std::string_view bytes(reinterpret_cast<const char*>(data), size);
  const Cut whole = cut(bytes, bytes.size() + 1);
  // every byte is a length byte, a payload byte, a refused zero or held
  std::size_t accounted = whole.pending + static_cast<std::size_t>(whole.zero_length_bytes);
  for (const std::string& f : whole.frames) {
    if (f.empty() || f.size() > 255) return "a frame of " + std::to_string(f.size()) + " bytes";
    accounted += f.size() + 1;
  }
  if (accounted != size) {
    return std::to_string(accounted) + " bytes accounted for of " + std::to_string(size);
  }
  // the same frames whatever the reads (the first byte picks a second chunk size)
  const std::size_t chunks[] = {1, size ? 1 + data[0] % 13u : 1};
  for (const std::size_t chunk : chunks) {
    const Cut other = cut(bytes, chunk);
    if (other.frames != whole.frames || other.zero_length_bytes != whole.zero_length_bytes ||
        other.pending != whole.pending) {
      return "reads of " + std::to_string(chunk) + " bytes give other frames";
    }
  }
  for (const std::string& f : whole.frames) {
    if (std::string v = check_frame(f, robot); !v.empty()) return v;
  }
  return {};
}

}  // namespace scaratwin::fuzz
