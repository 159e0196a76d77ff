// The one place where wire units (mm, degrees, centidegrees, milliseconds) meet SI (m, rad,
// s). Decoding reads decimal fields exactly (mantissa / 10^k is correctly rounded because
// the mantissa has at most 15 digits); encoding rounds to the wire precision and refuses
// values that are not finite or do not fit the field.
#pragma once

#include <cmath>
#include <cstdint>
#include <optional>

#include "scaratwin/core/units.hpp"
#include "scaratwin/protocol/codec_core.h"

namespace scaratwin::protocol::wire {

// Decimals written on the TCP link: 1 um for lengths, 1e-4 degree for angles.
inline constexpr std::uint8_t kMmDecimals = 3;
inline constexpr std::uint8_t kDegDecimals = 4;

// Value of a decimal (or integer) field divided by 10^extra_decimals, correctly rounded.
inline double decimal_field(const core::Packet& p, std::uint8_t i, int extra_decimals = 0) {
  static constexpr double kPow10[] = {1e0, 1e1, 1e2,  1e3,  1e4,  1e5,  1e6,  1e7,
                                      1e8, 1e9, 1e10, 1e11, 1e12, 1e13, 1e14, 1e15};
  if ((p.micro_mask >> i) & 1u) return p.value[i] / kPow10[6 + extra_decimals];
  const char* s = p.text(i);
  const std::uint16_t n = p.field_length[i];
  std::uint16_t k = 0;
  const bool negative = n > 0 && s[0] == '-';
  if (negative) k = 1;
  std::uint64_t mantissa = 0;
  int frac_digits = 0;
  bool in_fraction = false;
  for (; k < n; ++k) {
    if (s[k] == '.') {
      in_fraction = true;
      continue;
    }
    mantissa = mantissa * 10u + static_cast<std::uint64_t>(s[k] - '0');
    if (in_fraction) ++frac_digits;
  }
  const double v = static_cast<double>(mantissa) / kPow10[frac_digits + extra_decimals];
  return negative ? -v : v;
}

// decoding: wire -> SI
inline double mm_field_to_m(const core::Packet& p, std::uint8_t i) {
  return decimal_field(p, i, 3);
}
inline double deg_field_to_rad(const core::Packet& p, std::uint8_t i) {
  return deg_to_rad(decimal_field(p, i));
}
inline double cdeg_to_rad(std::int32_t cdeg) { return deg_to_rad(cdeg / 100.0); }
inline double ms_to_s(std::int32_t ms) { return ms / 1000.0; }

// encoding: SI -> wire integers; nullopt when not finite or outside int32.
inline std::optional<std::int32_t> round_i32(double v) {
  if (!std::isfinite(v) || v < -2147483648.0 || v > 2147483647.0) return std::nullopt;
  const double r = std::round(v);
  if (r < -2147483648.0 || r > 2147483647.0) return std::nullopt;
  return static_cast<std::int32_t>(r);
}
// Metres as mm scaled by 10^kMmDecimals (for Encoder::add_fixed).
inline std::optional<std::int32_t> m_to_scaled_mm(double m) { return round_i32(m * 1e6); }
// Radians as degrees scaled by 10^kDegDecimals.
inline std::optional<std::int32_t> rad_to_scaled_deg(double rad) {
  return round_i32(rad_to_deg(rad) * 1e4);
}
inline std::optional<std::int32_t> rad_to_cdeg(double rad) {
  return round_i32(rad_to_deg(rad) * 100.0);
}
inline std::optional<std::int32_t> s_to_ms(double s) { return round_i32(s * 1000.0); }

}  // namespace scaratwin::protocol::wire
