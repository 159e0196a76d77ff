// Unit conversions used at the edges (CLI, wire, UI, firmware). Everything inside scaratwin is
// SI: metres, radians, seconds.
#pragma once

#include <numbers>

namespace scaratwin {

inline constexpr double kPi = std::numbers::pi;
inline constexpr double kDegPerRad = 180.0 / kPi;

constexpr double deg_to_rad(double deg) { return deg / kDegPerRad; }
constexpr double rad_to_deg(double rad) { return rad * kDegPerRad; }
constexpr double m_to_mm(double m) { return m * 1000.0; }
constexpr double mm_to_m(double mm) { return mm / 1000.0; }

}  // namespace scaratwin
