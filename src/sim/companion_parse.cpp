// The companion dialect's pure parts: length-prefixed framing and the decoding of one frame
// (docs/protocol.md section 13). No I/O: the server (companion.cpp) and the fuzz target
// (fuzz/fuzz_companion.cpp) both use them.
#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdlib>
#include <string>
#include <vector>

#include <fmt/format.h>

#include "scaratwin/core/units.hpp"
#include "scaratwin/sim/companion.hpp"

namespace scaratwin::sim {

// ---- framing --------------------------------------------------------------------------------

void CompanionFramer::feed(std::string_view bytes,
                           const std::function<void(std::string_view)>& on_frame,
                           const std::function<void(const std::string&)>& on_error) {
  std::size_t i = 0;
  while (i < bytes.size()) {
    if (!have_) {
      const auto len = static_cast<unsigned char>(bytes[i++]);
      if (len == 0) {
        on_error("length byte 0 (a frame holds 1..255 bytes): skipped");
        continue;
      }
      have_ = true;
      need_ = len;
      payload_.clear();
      continue;
    }
    const std::size_t take = std::min(need_ - payload_.size(), bytes.size() - i);
    payload_.append(bytes.substr(i, take));
    i += take;
    if (payload_.size() == need_) {
      have_ = false;
      on_frame(payload_);
    }
  }
}

// ---- decoding -------------------------------------------------------------------------------

namespace {

using Kind = CompanionCommand::Kind;

Error bad(std::string message) {
  return Error{static_cast<int>(SimError::kBadArgument), std::move(message)};
}

std::vector<std::string_view> split_fields(std::string_view args) {
  std::vector<std::string_view> fields;
  std::size_t start = 0;
  for (;;) {
    const std::size_t comma = args.find(',', start);
    fields.push_back(args.substr(start, comma - start));
    if (comma == std::string_view::npos) break;
    start = comma + 1;
  }
  return fields;
}

// A number in the invariant culture: [+-] digits [. digits] [(e|E) [+-] digits], at least one
// digit before the exponent. No spaces, no ',' decimals, no NaN or infinity.
Result<double> parse_number(std::string_view text, std::string_view what) {
  std::string_view t = text;
  const auto refuse = [&] {
    return bad(
        fmt::format("{} '{}' is not a number (expected e.g. 0.12 or -30.5: digits, '.' "
                    "decimals, no spaces)",
                    what, text));
  };
  // one sign at most (from_chars takes '-' only, so a '+' is dropped first)
  const bool plus = !t.empty() && t[0] == '+';
  if (plus) t.remove_prefix(1);
  std::size_t k = (!plus && !t.empty() && t[0] == '-') ? 1 : 0;
  std::size_t digits = 0;
  while (k < t.size() && std::isdigit(static_cast<unsigned char>(t[k]))) ++k, ++digits;
  if (k < t.size() && t[k] == '.') {
    ++k;
    while (k < t.size() && std::isdigit(static_cast<unsigned char>(t[k]))) ++k, ++digits;
  }
  if (digits == 0) return refuse();
  if (k < t.size() && (t[k] == 'e' || t[k] == 'E')) {
    ++k;
    if (k < t.size() && (t[k] == '+' || t[k] == '-')) ++k;
    std::size_t exp_digits = 0;
    while (k < t.size() && std::isdigit(static_cast<unsigned char>(t[k]))) ++k, ++exp_digits;
    if (exp_digits == 0) return refuse();
  }
  if (k != t.size()) return refuse();
  double v = 0.0;
  const auto [end, ec] = std::from_chars(t.data(), t.data() + t.size(), v);
  if (ec == std::errc::result_out_of_range) {
    // from_chars leaves v alone when the value does not fit: one too small for a double (as
    // 1e-1121, found by the fuzzer) reads as a signed zero, as strtod reads it (our programs
    // stay in the C locale); one too large is refused below as not finite
    v = std::strtod(std::string(t).c_str(), nullptr);
  } else if (ec != std::errc() || end != t.data() + t.size()) {
    return refuse();
  }
  if (!std::isfinite(v)) return refuse();
  return v;
}

Status check_arity(std::string_view command, const std::vector<std::string_view>& fields,
                   std::size_t want, const char* usage) {
  if (fields.size() == want) return Ok{};
  return bad(fmt::format("{} takes {} field{}, got {} (expected {})", command, want,
                         want == 1 ? "" : "s", fields.size(), usage));
}

}  // namespace

Result<CompanionCommand> parse_companion(std::string_view payload, const RobotModel& robot) {
  for (const char c : payload) {
    const auto u = static_cast<unsigned char>(c);
    if (u < 0x20 || u > 0x7e) {
      return bad(
          fmt::format("byte 0x{:02x} is not printable ASCII (a frame is text: "
                      "Command:arg,arg,...)",
                      u));
    }
  }
  const std::size_t colon = payload.find(':');
  if (colon == std::string_view::npos) {
    return bad("no ':' (expected Command:arg,arg,..., e.g. ModGrab:1)");
  }
  const std::string_view command = payload.substr(0, colon);
  const std::vector<std::string_view> f = split_fields(payload.substr(colon + 1));
  CompanionCommand out;
  if (command == "Name") {
    if (Status st = check_arity(command, f, 1, "Name:<text>"); !st) return st.error();
    out.kind = Kind::kName;
    out.name = std::string(f[0]);
    return out;
  }
  if (command == "ModRobot") {
    if (f.size() < 4) {
      return bad(fmt::format(
          "ModRobot takes at least 4 fields, got {} (expected ModRobot:d1_m,q2_deg,q3_deg,q4_deg)",
          f.size()));
    }
    static constexpr const char* kNames[] = {"d1", "q2", "q3", "q4"};
    for (int j = 0; j < 4; ++j) {
      auto v = parse_number(f[j], fmt::format("ModRobot field {} ({})", j + 1, kNames[j]));
      if (!v) return v.error();
      const JointLimit& lim = robot.limits[j];
      if (j == 0) {
        // metres; the slack only absorbs the rounding of the limits' conversion
        if (*v < lim.min - 1e-12 || *v > lim.max + 1e-12) {
          return bad(fmt::format("ModRobot d1 {} m is outside the joint limits {}..{} m", *v,
                                 lim.min, lim.max));
        }
        out.q[0] = std::clamp(*v, lim.min, lim.max);
      } else {
        const double lo = rad_to_deg(lim.min), hi = rad_to_deg(lim.max);
        if (*v < lo - 1e-9 || *v > hi + 1e-9) {
          return bad(
              fmt::format("ModRobot {} {} deg is outside the joint limits {:.6g}..{:.6g} deg",
                          kNames[j], *v, lo, hi));
        }
        out.q[j] = std::clamp(deg_to_rad(*v), lim.min, lim.max);
      }
    }
    out.kind = Kind::kModRobot;
    return out;
  }
  if (command == "ModGrab") {
    if (Status st = check_arity(command, f, 1, "ModGrab:1 or ModGrab:0"); !st) return st.error();
    if (f[0] != "0" && f[0] != "1") {
      return bad(fmt::format("ModGrab '{}': expected 1 (grasp) or 0 (release)", f[0]));
    }
    out.kind = Kind::kModGrab;
    out.grab = f[0] == "1";
    return out;
  }
  if (command == "NewObj") {
    if (Status st = check_arity(command, f, 1, "NewObj:1, 2 or 3"); !st) return st.error();
    if (f[0] != "1" && f[0] != "2" && f[0] != "3") {
      return bad(fmt::format("NewObj '{}': expected 1 (red), 2 (green) or 3 (blue)", f[0]));
    }
    out.kind = Kind::kNewObj;
    out.color = static_cast<CubeColor>(f[0][0] - '1');
    return out;
  }
  if (command == "Camera") {
    if (Status st = check_arity(command, f, 3, "Camera:<camera>,<path>,<name>"); !st) {
      return st.error();
    }
    if (f[0].empty()) return bad("Camera: the camera field is empty (e.g. Camera:Center,,image)");
    out.kind = Kind::kCamera;
    out.camera = std::string(f[0]);
    out.path = std::string(f[1]);
    out.file = std::string(f[2]);
    return out;
  }
  return bad(fmt::format("unknown command '{}' (known: Name, ModRobot, ModGrab, NewObj, Camera)",
                         command));
}

}  // namespace scaratwin::sim
