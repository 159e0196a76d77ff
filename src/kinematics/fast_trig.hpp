// Internal: sine/cosine and atan2 for the kinematics hot path, as inline polynomials (the
// fdlibm kernels: error below 1 ulp on the reduced range), about 3x faster than the libm
// calls, which cost more than the rest of FK and IK together. Valid for |x| < 1e5 rad; larger
// or non-finite arguments fall back to libm. Checked against libm in tests/core.
#pragma once

#include <cmath>

namespace scaratwin::detail {

inline void sincos_fast(double x, double& s, double& c) {
  if (!(std::abs(x) < 1e5)) {
    s = std::sin(x);
    c = std::cos(x);
    return;
  }
  // x = n * pi/2 + y, Cody-Waite reduction with pi/2 split in two (33 + 53 bits).
  constexpr double kInvPio2 = 6.36619772367581382433e-01;
  constexpr double kPio2Hi = 1.57079632673412561417e+00;
  constexpr double kPio2Lo = 6.07710050650619224932e-11;
  const double n = std::nearbyint(x * kInvPio2);
  const double y = (x - n * kPio2Hi) - n * kPio2Lo;
  const double z = y * y;
  // fdlibm __kernel_sin and __kernel_cos on [-pi/4, pi/4].
  const double sr = 1.58969099521155010221e-10;
  const double sp =
      -1.66666666666666324348e-01 +
      z * (8.33333333332248946124e-03 +
           z * (-1.98412698298579493134e-04 +
                z * (2.75573137070700676789e-06 + z * (-2.50507602534068634195e-08 + z * sr))));
  const double sy = y + y * z * sp;
  const double cp =
      z * (4.16666666666666019037e-02 +
           z * (-1.38888888888741095749e-03 +
                z * (2.48015872894767294178e-05 +
                     z * (-2.75573143513906633035e-07 +
                          z * (2.08757232129817482790e-09 + z * -1.13596475577881948265e-11)))));
  const double hz = 0.5 * z;
  const double w = 1.0 - hz;
  const double cy = w + (((1.0 - w) - hz) + z * cp);
  switch (static_cast<long>(n) & 3) {
    case 0:
      s = sy;
      c = cy;
      break;
    case 1:
      s = cy;
      c = -sy;
      break;
    case 2:
      s = -sy;
      c = -cy;
      break;
    default:
      s = -cy;
      c = sy;
      break;
  }
}

// atan2 without data-dependent branches (random IK targets made the branchy version pay a
// misprediction per call): fdlibm's atan kernel, its three-interval reduction folded into one
// division of table-selected linear forms of min(|x|,|y|) and max(|x|,|y|).
inline double atan2_fast(double y, double x) {
  const double ax = std::abs(x), ay = std::abs(y);
  if (!(ax > 0.0 || ay > 0.0) || !(ax < INFINITY) || !(ay < INFINITY)) return std::atan2(y, x);
  const double mn = ay < ax ? ay : ax;
  const double mx = ay < ax ? ax : ay;
  // interval of z = mn / mx: [0, 0.4375), [0.4375, 0.6875), [0.6875, 1]
  const int id = static_cast<int>(mn >= 0.4375 * mx) + static_cast<int>(mn >= 0.6875 * mx);
  // reduced argument (a z + b) / (c + d z): z, (2z - 1) / (2 + z), (z - 1) / (z + 1)
  static constexpr double kA[] = {1.0, 2.0, 1.0};
  static constexpr double kB[] = {0.0, -1.0, -1.0};
  static constexpr double kD[] = {0.0, 1.0, 1.0};
  static constexpr double kC[] = {1.0, 2.0, 1.0};
  static constexpr double kHi[] = {0.0, 4.63647609000806093515e-01, 7.85398163397448278999e-01};
  static constexpr double kLo[] = {0.0, 2.26987774529616870924e-17, 3.06161699786838301793e-17};
  const double z = (kA[id] * mn + kB[id] * mx) / (kC[id] * mx + kD[id] * mn);
  const double w = z * z;
  const double zz = w * w;
  const double s1 =
      w *
      (3.33333333333329318027e-01 +
       zz * (1.42857142725034663711e-01 +
             zz * (9.09088713343650656196e-02 +
                   zz * (6.66107313738753120669e-02 +
                         zz * (4.97687799461593236017e-02 + zz * 1.62858201153657823623e-02)))));
  const double s2 =
      zz * (-1.99999999998764832476e-01 +
            zz * (-1.11111104054623557880e-01 +
                  zz * (-7.69187620504482999495e-02 +
                        zz * (-5.83357013379057348645e-02 + zz * -3.65315727442169155270e-02))));
  double t = kHi[id] - ((z * (s1 + s2) - kLo[id]) - z);
  constexpr double kPio2Hi = 1.57079632679489655800e+00;
  constexpr double kPio2Lo = 6.12323399573676603587e-17;
  constexpr double kPiHi = 3.14159265358979311600e+00;
  constexpr double kPiLo = 1.22464679914735317720e-16;
  const double swapped = kPio2Hi - (t - kPio2Lo);
  t = ay > ax ? swapped : t;
  const double mirrored = kPiHi - (t - kPiLo);
  t = x < 0.0 ? mirrored : t;
  return std::copysign(t, y);
}

}  // namespace scaratwin::detail
