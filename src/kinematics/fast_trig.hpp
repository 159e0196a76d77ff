// Internal: sine/cosine and atan2 for the kinematics hot path, as inline polynomials (the
// fdlibm kernels: error below 1 ulp on the reduced range), several times faster than the libm
// calls, which cost more than the rest of FK and IK together. Valid for |x| < 1e5 rad; larger
// or non-finite arguments fall back to libm. Checked against libm in tests/core.
//
// Each function comes as a scalar and as a two-lane form (V2d: two doubles in one SSE2 / NEON
// register, GCC/clang vector extension, so baseline x86-64 and arm64 both get it without any
// machine flag). FK evaluates its two angles and IK its elbow branches side by side in the two
// lanes. Nothing here branches on the data except the rare fallback to libm: random targets
// defeat branch prediction, and a mispredicted branch costs as much as a polynomial.
#pragma once

#include <bit>
#include <cmath>
#include <cstdint>
#include <type_traits>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

namespace scaratwin::detail {

// Two doubles in one vector register; a lane mask is a V2d whose lanes are all ones or all
// zeros (the result of a comparison). The masks go through SSE2 intrinsics on x86-64: written
// with the vector extension's own comparisons, g++ 12 turns combined masks into per-lane
// scalar code.
using V2d = double __attribute__((vector_size(16)));
using V2i = std::int64_t __attribute__((vector_size(16)));
using Mask2 = V2d;

inline V2d splat(double x) { return V2d{x, x}; }

#if defined(__SSE2__)
inline Mask2 lt(V2d a, V2d b) { return _mm_cmplt_pd(a, b); }
inline Mask2 le(V2d a, V2d b) { return _mm_cmple_pd(a, b); }
inline Mask2 mask_and(Mask2 a, Mask2 b) { return _mm_and_pd(a, b); }
inline Mask2 mask_or(Mask2 a, Mask2 b) { return _mm_or_pd(a, b); }
// b and not a.
inline Mask2 mask_andnot(Mask2 a, Mask2 b) { return _mm_andnot_pd(a, b); }
// Lane minimum and maximum of numbers (no NaN).
inline V2d min(V2d a, V2d b) { return _mm_min_pd(a, b); }
inline V2d max(V2d a, V2d b) { return _mm_max_pd(a, b); }
// Bitwise select: a where the mask lane is all ones, b where it is zero.
inline V2d select(Mask2 m, V2d a, V2d b) {
  return _mm_or_pd(_mm_and_pd(m, a), _mm_andnot_pd(m, b));
}
// Bit b set when lane b of the mask is set.
inline int lanes(Mask2 m) { return _mm_movemask_pd(m); }
#else
inline Mask2 lt(V2d a, V2d b) { return std::bit_cast<V2d>(a < b); }
inline Mask2 le(V2d a, V2d b) { return std::bit_cast<V2d>(a <= b); }
inline Mask2 mask_and(Mask2 a, Mask2 b) {
  return std::bit_cast<V2d>(std::bit_cast<V2i>(a) & std::bit_cast<V2i>(b));
}
inline Mask2 mask_or(Mask2 a, Mask2 b) {
  return std::bit_cast<V2d>(std::bit_cast<V2i>(a) | std::bit_cast<V2i>(b));
}
inline Mask2 mask_andnot(Mask2 a, Mask2 b) {
  return std::bit_cast<V2d>(~std::bit_cast<V2i>(a) & std::bit_cast<V2i>(b));
}
inline V2d select(Mask2 m, V2d a, V2d b) {
  const V2i mi = std::bit_cast<V2i>(m);
  return std::bit_cast<V2d>((mi & std::bit_cast<V2i>(a)) | (~mi & std::bit_cast<V2i>(b)));
}
inline V2d min(V2d a, V2d b) { return select(lt(a, b), a, b); }
inline V2d max(V2d a, V2d b) { return select(lt(b, a), a, b); }
inline int lanes(Mask2 m) {
  const V2i mi = std::bit_cast<V2i>(m);
  return static_cast<int>(mi[0] != 0) | (static_cast<int>(mi[1] != 0) << 1);
}
#endif

// |x| of each lane (clears the sign bits), and the sign bits of x alone.
inline V2d abs(V2d x) {
  return std::bit_cast<V2d>(std::bit_cast<V2i>(x) & ~std::bit_cast<V2i>(splat(-0.0)));
}
inline V2i sign_bits(V2d x) { return std::bit_cast<V2i>(x) & std::bit_cast<V2i>(splat(-0.0)); }

// Scalar select without a branch.
inline double select(bool m, double a, double b) {
  const std::uint64_t mask = -static_cast<std::uint64_t>(m);
  return std::bit_cast<double>((mask & std::bit_cast<std::uint64_t>(a)) |
                               (~mask & std::bit_cast<std::uint64_t>(b)));
}

namespace trig {

// 1.5 * 2^52: adding and subtracting it rounds a double of magnitude below 2^51 to the nearest
// integer (ties to even, as nearbyint in the default rounding mode), and the low bits of the
// sum hold that integer modulo 2^k. Without SSE4.1, nearbyint is a libm call.
constexpr double kRoundShift = 6755399441055744.0;
constexpr double kInvPio2 = 6.36619772367581382433e-01;
constexpr double kPio2Hi1 = 1.57079632673412561417e+00;  // pi/2 in 33 + 53 bits
constexpr double kPio2Lo1 = 6.07710050650619224932e-11;

// fdlibm __kernel_sin and __kernel_cos on [-pi/4, pi/4], for a double or a V2d.
template <typename T>
inline void kernels(T y, T& sy, T& cy) {
  const T z = y * y;
  const T sp = -1.66666666666666324348e-01 +
               z * (8.33333333332248946124e-03 +
                    z * (-1.98412698298579493134e-04 +
                         z * (2.75573137070700676789e-06 +
                              z * (-2.50507602534068634195e-08 + z * 1.58969099521155010221e-10))));
  sy = y + y * z * sp;
  const T cp =
      z * (4.16666666666666019037e-02 +
           z * (-1.38888888888741095749e-03 +
                z * (2.48015872894767294178e-05 +
                     z * (-2.75573143513906633035e-07 +
                          z * (2.08757232129817482790e-09 + z * -1.13596475577881948265e-11)))));
  const T hz = 0.5 * z;
  const T w = 1.0 - hz;
  cy = w + (((1.0 - w) - hz) + z * cp);
}

// fdlibm's atan coefficients aT[0..10] and reduction constants.
inline constexpr double kAtanT[11] = {
    3.33333333333329318027e-01,  -1.99999999998764832476e-01, 1.42857142725034663711e-01,
    -1.11111104054623557880e-01, 9.09088713343650656196e-02,  -7.69187620504482999495e-02,
    6.66107313738753120669e-02,  -5.83357013379057348645e-02, 4.97687799461593236017e-02,
    -3.65315727442169155270e-02, 1.62858201153657823623e-02};
constexpr double kAtanHi1 = 4.63647609000806093515e-01;  // atan(1/2)
constexpr double kAtanLo1 = 2.26987774529616870924e-17;
constexpr double kAtanHi2 = 7.85398163397448278999e-01;  // atan(1)
constexpr double kAtanLo2 = 3.06161699786838301793e-17;
constexpr double kPio2Hi = 1.57079632679489655800e+00;
constexpr double kPio2Lo = 6.12323399573676603587e-17;
constexpr double kPiHi = 3.14159265358979311600e+00;
constexpr double kPiLo = 1.22464679914735317720e-16;

// The same constants for the two-lane atan2, in storage that is writable but never written:
// g++ 12 builds each constant vector from a scalar (two instructions), while a global it
// cannot prove constant is read straight from memory as an operand of the arithmetic. The IK
// hot path uses about thirty of them.
struct alignas(16) AtanLaneConstants {
  V2d t[11];
  V2d hi1, hi2, lo1, lo2, pio2_hi, pio2_lo, pi_hi, pi_lo, split1, split2, half;
};
#define SCARATWIN_SPLAT(c) \
  V2d { c, c }
inline AtanLaneConstants atan_lane_constants = {
    {SCARATWIN_SPLAT(kAtanT[0]), SCARATWIN_SPLAT(kAtanT[1]), SCARATWIN_SPLAT(kAtanT[2]),
     SCARATWIN_SPLAT(kAtanT[3]), SCARATWIN_SPLAT(kAtanT[4]), SCARATWIN_SPLAT(kAtanT[5]),
     SCARATWIN_SPLAT(kAtanT[6]), SCARATWIN_SPLAT(kAtanT[7]), SCARATWIN_SPLAT(kAtanT[8]),
     SCARATWIN_SPLAT(kAtanT[9]), SCARATWIN_SPLAT(kAtanT[10])},
    SCARATWIN_SPLAT(kAtanHi1),
    SCARATWIN_SPLAT(kAtanHi2),
    SCARATWIN_SPLAT(kAtanLo1),
    SCARATWIN_SPLAT(kAtanLo2),
    SCARATWIN_SPLAT(kPio2Hi),
    SCARATWIN_SPLAT(kPio2Lo),
    SCARATWIN_SPLAT(kPiHi),
    SCARATWIN_SPLAT(kPiLo),
    SCARATWIN_SPLAT(0.4375),
    SCARATWIN_SPLAT(0.6875),
    SCARATWIN_SPLAT(0.5)};
#undef SCARATWIN_SPLAT

template <typename T>
inline T atan_coef(int i) {
  if constexpr (std::is_same_v<T, double>) {
    return kAtanT[i];
  } else {
    return atan_lane_constants.t[i];
  }
}

// fdlibm's atan polynomial: atan(z) ~ z - z w Q(w), w = z^2, |z| <= 7/16. Q is evaluated by
// Estrin's scheme (pairs, then powers w^2, w^4, w^8) rather than fdlibm's two Horner chains:
// half the dependent steps, and IK's critical path runs through it.
template <typename T>
inline T atan_tail(T z) {
  const T w = z * z;
  const T w2 = w * w;
  const T w4 = w2 * w2;
  const T p01 = atan_coef<T>(0) + w * atan_coef<T>(1);
  const T p23 = atan_coef<T>(2) + w * atan_coef<T>(3);
  const T p45 = atan_coef<T>(4) + w * atan_coef<T>(5);
  const T p67 = atan_coef<T>(6) + w * atan_coef<T>(7);
  const T p89 = atan_coef<T>(8) + w * atan_coef<T>(9);
  const T q03 = p01 + w2 * p23;
  const T q47 = p45 + w2 * p67;
  const T q8a = p89 + w2 * atan_coef<T>(10);
  const T q = (q03 + w4 * q47) + (w4 * w4) * q8a;
  return (z * w) * q;  // z^3 is ready long before q
}

constexpr std::uint64_t kSignBit = std::uint64_t{1} << 63;

}  // namespace trig

inline void sincos_fast(double x, double& s, double& c) {
  using namespace trig;
  if (!(std::abs(x) < 1e5)) {
    s = std::sin(x);
    c = std::cos(x);
    return;
  }
  // x = n * pi/2 + y, Cody-Waite reduction with pi/2 split in two (33 + 53 bits).
  const double shifted = x * kInvPio2 + kRoundShift;
  const double n = shifted - kRoundShift;
  const double y = (x - n * kPio2Hi1) - n * kPio2Lo1;
  double sy, cy;
  kernels(y, sy, cy);
  // quadrant n mod 4: odd swaps sine and cosine, bit 1 of n (of n + 1) negates the sine (the
  // cosine).
  const std::uint64_t q = std::bit_cast<std::uint64_t>(shifted);
  const bool odd = (q & 1) != 0;
  s = std::bit_cast<double>(std::bit_cast<std::uint64_t>(select(odd, cy, sy)) ^ (q & 2) << 62);
  c = std::bit_cast<double>(std::bit_cast<std::uint64_t>(select(odd, sy, cy)) ^ ((q + 1) & 2)
                                                                                    << 62);
}

// Both lanes at once; the same results as sincos_fast lane by lane.
inline void sincos_fast(V2d x, V2d& s, V2d& c) {
  using namespace trig;
  if (!(std::abs(x[0]) < 1e5 && std::abs(x[1]) < 1e5)) [[unlikely]] {
    double s0, c0, s1, c1;
    sincos_fast(x[0], s0, c0);
    sincos_fast(x[1], s1, c1);
    s = V2d{s0, s1};
    c = V2d{c0, c1};
    return;
  }
  const V2d shifted = x * kInvPio2 + kRoundShift;
  const V2d n = shifted - kRoundShift;
  const V2d y = (x - n * kPio2Hi1) - n * kPio2Lo1;
  V2d sy, cy;
  kernels(y, sy, cy);
  const V2i q = std::bit_cast<V2i>(shifted);
  const Mask2 odd = std::bit_cast<V2d>(-(q & 1));
  s = std::bit_cast<V2d>(std::bit_cast<V2i>(select(odd, cy, sy)) ^ (q & 2) << 62);
  c = std::bit_cast<V2d>(std::bit_cast<V2i>(select(odd, sy, cy)) ^ ((q + 1) & 2) << 62);
}

// atan2 without data-dependent branches: fdlibm's atan kernel, its three-interval reduction
// folded into one division (mn - f mx) / (mx + f mn) of min(|x|,|y|) and max(|x|,|y|), f = 0,
// 1/2 or 1 (the same quotient as fdlibm's, since halving is exact).
inline double atan2_fast(double y, double x) {
  using namespace trig;
  const double ax = std::abs(x), ay = std::abs(y);
  if (!(ax > 0.0 || ay > 0.0) || !(ax < INFINITY) || !(ay < INFINITY)) return std::atan2(y, x);
  const double mn = ay < ax ? ay : ax;
  const double mx = ay < ax ? ax : ay;
  // interval of z = mn / mx: [0, 0.4375), [0.4375, 0.6875), [0.6875, 1]
  const bool i1 = mn >= 0.4375 * mx, i2 = mn >= 0.6875 * mx;
  const double f = select(i1, 0.5, 0.0) + select(i2, 0.5, 0.0);
  const double hi = select(i2, kAtanHi2, select(i1, kAtanHi1, 0.0));
  const double lo = select(i2, kAtanLo2, select(i1, kAtanLo1, 0.0));
  const double z = (mn - f * mx) / (mx + f * mn);
  const double t = hi - ((atan_tail(z) - lo) - z);
  // the octant in one step: a - (u - a_lo) with (a, u) = (0, -t), (pi/2, t) when |y| > |x|,
  // (pi, t) when x < 0, (pi/2, -t) for both.
  const bool swapped = ay > ax, neg = x < 0.0;
  const double a = select(neg && !swapped, kPiHi, select(swapped, kPio2Hi, 0.0));
  const double a_lo = select(neg && !swapped, kPiLo, select(swapped, kPio2Lo, 0.0));
  const double u = select(swapped != neg, t, -t);
  const double r = a - (u - a_lo);
  return std::bit_cast<double>(std::bit_cast<std::uint64_t>(r) |
                               (std::bit_cast<std::uint64_t>(y) & kSignBit));
}

namespace trig {

// Whether both lanes are finite and not (0, 0): the lanes atan2_lanes handles.
inline bool atan2_lanes_fine(V2d y, V2d x) {
  const V2d ax = abs(x), ay = abs(y);
  const V2d inf = splat(INFINITY), zero = splat(0.0);
  return lanes(mask_and(mask_or(lt(zero, ax), lt(zero, ay)), mask_and(lt(ax, inf), lt(ay, inf)))) ==
         3;
}

// atan2_fast of both lanes, for lanes that atan2_lanes_fine accepts.
inline V2d atan2_lanes(V2d y, V2d x) {
  const V2d ax = abs(x), ay = abs(y);
  const V2d zero = splat(0.0);
  const Mask2 swapped = lt(ax, ay);
  const V2d mn = min(ay, ax);
  const V2d mx = max(ay, ax);
  const AtanLaneConstants& k = atan_lane_constants;
  const Mask2 i1 = le(k.split1 * mx, mn), i2 = le(k.split2 * mx, mn);
  // i2 implies i1, so a masked constant stands for select(i1, c, 0). The three candidate
  // quotients are formed while the interval is being decided (the same operations as
  // (mn - f mx) / (mx + f mn) for f = 0, 1/2, 1).
  const V2d hi = select(i2, k.hi2, mask_and(i1, k.hi1));
  const V2d lo = select(i2, k.lo2, mask_and(i1, k.lo1));
  const V2d num = select(i2, mn - mx, select(i1, mn - k.half * mx, mn));
  const V2d den = select(i2, mx + mn, select(i1, mx + k.half * mn, mx));
  const V2d z = num / den;
  const V2d t = hi - ((atan_tail(z) - lo) - z);
  // the octant in one step, as in the scalar form.
  const Mask2 neg = lt(x, zero);
  const Mask2 pi_side = mask_andnot(swapped, neg);
  const V2d a = select(pi_side, k.pi_hi, mask_and(swapped, k.pio2_hi));
  const V2d a_lo = select(pi_side, k.pi_lo, mask_and(swapped, k.pio2_lo));
  // u = t where exactly one of swapped and neg holds, else -t: flip the sign bit of t.
  const V2i flip =
      ~(std::bit_cast<V2i>(swapped) ^ std::bit_cast<V2i>(neg)) & std::bit_cast<V2i>(splat(-0.0));
  const V2d u = std::bit_cast<V2d>(std::bit_cast<V2i>(t) ^ flip);
  const V2d r = a - (u - a_lo);
  return std::bit_cast<V2d>(std::bit_cast<V2i>(r) | sign_bits(y));
}

}  // namespace trig

// Both lanes at once; the same results as atan2_fast lane by lane.
inline V2d atan2_fast(V2d y, V2d x) {
  if (!trig::atan2_lanes_fine(y, x)) [[unlikely]] {
    return V2d{atan2_fast(y[0], x[0]), atan2_fast(y[1], x[1])};
  }
  return trig::atan2_lanes(y, x);
}

// Four atan2 at once (r0 = atan2(y0, x0), r1 = atan2(y1, x1), lane by lane): one pass over
// the constants for both pairs. `checked` = false skips the test of the lanes for callers
// that know every lane finite and not (0, 0).
inline void atan2_fast(V2d y0, V2d x0, V2d y1, V2d x1, V2d& r0, V2d& r1, bool checked = true) {
  if (checked && !(trig::atan2_lanes_fine(y0, x0) && trig::atan2_lanes_fine(y1, x1))) [[unlikely]] {
    r0 = atan2_fast(y0, x0);
    r1 = atan2_fast(y1, x1);
    return;
  }
  r0 = trig::atan2_lanes(y0, x0);
  r1 = trig::atan2_lanes(y1, x1);
}

}  // namespace scaratwin::detail
