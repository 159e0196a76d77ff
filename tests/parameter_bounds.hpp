// How close an identified parameter must be to the truth (docs/calibration.md, "How close is
// close"): within 3 of its standard errors, as before, and also within an absolute bound of
// its kind, so that a fit which inflates its own errors cannot pass.
#pragma once

#include <cmath>
#include <limits>
#include <string_view>

namespace scaratwin::test {

inline constexpr double kBoundMm = 0.3;       // lengths and offsets, mm
inline constexpr double kBoundDeg = 0.3;      // angles, deg
inline constexpr double kBoundPercent = 0.5;  // scales and gains, percent
inline constexpr double kBoundK1 = 0.005;     // the lens's radial k1 (dimensionless)
// The webcam's pose fitted from one view of the printed pattern alone (tests/vision): a lateral
// shift of the camera and a tilt that makes up for it look alike in one top-down view, so its
// position is known less well than the calibration's (0.59 mm off at 2 standard errors in
// WebcamFit.RecoversASyntheticCamera..., 0.1 px of noise).
inline constexpr double kBoundOneViewMm = 1.0;

// The bound of a parameter by its key's unit (`a2_mm`, `j2_zero_deg`, `z_scale_percent`,
// `camera_k1`); NaN for a key of no known unit, which fails every comparison.
inline double absolute_bound(std::string_view key) {
  const auto ends = [&](std::string_view s) {
    return key.size() >= s.size() && key.substr(key.size() - s.size()) == s;
  };
  if (ends("_mm")) return kBoundMm;
  if (ends("_deg")) return kBoundDeg;
  if (ends("_percent")) return kBoundPercent;
  if (ends("k1")) return kBoundK1;
  return std::numeric_limits<double>::quiet_NaN();
}

}  // namespace scaratwin::test
