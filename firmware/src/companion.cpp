#include "companion.h"

#if defined(__AVR__)
#include <avr/pgmspace.h>
#define memcpy_flash memcpy_P
#else
#include <string.h>
#define PROGMEM
#define pgm_read_byte(p) (*(const uint8_t*)(p))
#define memcpy_flash memcpy
#endif

namespace fw {
namespace {

// floor(a / b) for b > 0
int32_t floor_div(int32_t a, int32_t b) { return a >= 0 ? a / b : -((-a + b - 1) / b); }

// the reasons live in flash: the Uno's RAM is short
const char kLimit[] PROGMEM = " beyond the limits ";
const char kBadNumber[] PROGMEM = " is not a whole number of steps";
const char kUnknown[] PROGMEM = " unknown (z, y, x or m)";
const char kTooLong[] PROGMEM = " too long";
const char kNotHomed[] PROGMEM = " not homed";
const char kBusy[] PROGMEM = " busy";
const char kHalted[] PROGMEM = " halted (send ~)";
const char* reason(CompanionError why) {
  switch (why) {
    case kCompErrLimit:
      return kLimit;
    case kCompErrBadNumber:
      return kBadNumber;
    case kCompErrUnknown:
      return kUnknown;
    case kCompErrTooLong:
      return kTooLong;
    case kCompErrNotHomed:
      return kNotHomed;
    case kCompErrBusy:
      return kBusy;
    case kCompErrHalted:
      break;
  }
  return kHalted;
}

// the limits as immediate constants (an array would take RAM on the AVR)
int32_t limit_min(uint8_t axis) {
  return axis == 0 ? desc::kLimitMinZ : axis == 1 ? desc::kLimitMinJ2 : desc::kLimitMinJ3;
}
int32_t limit_max(uint8_t axis) {
  return axis == 0 ? desc::kLimitMaxZ : axis == 1 ? desc::kLimitMaxJ2 : desc::kLimitMaxJ3;
}

struct Out {
  char* p;
  uint8_t cap;
  uint8_t n;
  void put(char c) {
    if (n + 1 < cap) p[n++] = c;  // the last byte is kept for '\n'
  }
  void put_flash(const char* s) {
    for (char c; (c = (char)pgm_read_byte(s)) != 0; ++s) put(c);
  }
  void put_i32(int32_t v) {
    char d[11];
    uint8_t k = 0;
    uint32_t u = v < 0 ? (uint32_t)(-(v + 1)) + 1u : (uint32_t)v;
    if (v < 0) put('-');
    do {
      d[k++] = (char)('0' + u % 10u);
      u /= 10u;
    } while (u != 0);
    while (k > 0) put(d[--k]);
  }
};

// the powers of ten a u32 has, largest first (flash)
const uint32_t kPow10[] PROGMEM = {1000000000ul, 100000000ul, 10000000ul, 1000000ul, 100000ul,
                                   10000ul,      1000ul,      100ul,      10ul,      1ul};

// One line "<letter><value>\n" into out at n; false if it did not fit.
bool report_line(char* out, uint8_t cap, uint8_t* n, char letter, uint32_t magnitude,
                 bool negative) {
  char line[13];
  uint8_t k = 0;
  line[k++] = letter;
  if (negative) line[k++] = '-';
  bool started = false;
  for (uint8_t i = 0; i < 10; ++i) {
    uint32_t p;
    memcpy_flash(&p, &kPow10[i], sizeof p);
    char d = '0';
    while (magnitude >= p) {
      magnitude -= p;
      ++d;
    }
    if (d != '0' || started || i == 9) {
      line[k++] = d;
      started = true;
    }
  }
  line[k++] = '\n';
  if (*n + k > cap) return false;
  for (uint8_t i = 0; i < k; ++i) out[(*n)++] = line[i];
  return true;
}

bool report_i32(char* out, uint8_t cap, uint8_t* n, char letter, int32_t v) {
  const uint32_t u = v < 0 ? (uint32_t)(-(v + 1)) + 1u : (uint32_t)v;
  return report_line(out, cap, n, letter, u, v < 0);
}

}  // namespace

uint8_t companion_report_lines(char* out, uint8_t cap, uint32_t t_us, const int32_t pos[kNumAxes],
                               const int32_t zero[kNumAxes], int32_t wrist_cdeg,
                               int32_t grip_cdeg) {
  uint8_t n = 0;
  const char axis_letter[kNumAxes] = {'z', 'y', 'x'};
  bool ok = report_line(out, cap, &n, 't', t_us, false);
  for (uint8_t i = 0; i < kNumAxes && ok; ++i)
    ok = report_i32(out, cap, &n, axis_letter[i], pos[i] - zero[i]);
  ok = ok && report_i32(out, cap, &n, 'w', wrist_cdeg);
  ok = ok && report_i32(out, cap, &n, 'g', grip_cdeg);
  return ok ? n : 0;
}

CompanionKind companion_parse(const char* line, uint8_t len, uint8_t* axis, int32_t* steps) {
  if (len == 0) return kCompanionUnknown;
  const char c = line[0];
  if (c == 'm') return len == 1 ? kCompanionMove : kCompanionUnknown;
  if (c == 'z') {
    *axis = 0;
  } else if (c == 'y') {
    *axis = 1;
  } else if (c == 'x') {
    *axis = 2;
  } else {
    return kCompanionUnknown;
  }
  uint8_t i = 1;
  const bool negative = i < len && line[i] == '-';
  if (negative) ++i;
  int32_t v = 0;
  uint8_t digits = 0;
  for (; i < len && line[i] >= '0' && line[i] <= '9'; ++i) {
    if (++digits > 9) return kCompanionBadLine;
    v = v * 10 + (line[i] - '0');
  }
  if (digits == 0) return kCompanionBadLine;
  if (i < len && line[i] == '.') {
    // a fraction (MATLAB's num2str writes 3419.6): rounded half away from zero
    ++i;
    if (i == len) return kCompanionBadLine;
    if (line[i] < '0' || line[i] > '9') return kCompanionBadLine;
    const bool up = line[i] >= '5';
    for (; i < len && line[i] >= '0' && line[i] <= '9'; ++i) {
    }
    if (up) ++v;
  }
  if (i != len) return kCompanionBadLine;
  *steps = negative ? -v : v;
  return kCompanionTarget;
}

void companion_range(const int32_t zero[kNumAxes], int32_t j2_target, uint16_t coupling_permille,
                     uint8_t axis, int32_t* lo, int32_t* hi) {
  int32_t shift = 0;
  if (axis == 2) {
    // J3's limits hold its joint count; its motor adds the J2 motor's coupling share
    const int32_t j2 = zero[1] + j2_target;
    shift = floor_div(j2 * (int32_t)coupling_permille, 1000);
  }
  *lo = limit_min(axis) + shift - zero[axis];
  *hi = limit_max(axis) + shift - zero[axis];
}

uint8_t companion_error_line(char* out, uint8_t cap, const char* line, uint8_t len,
                             CompanionError why, int32_t lo, int32_t hi, int8_t axis,
                             int32_t target) {
  Out o{out, cap, 0};
  static const char kError[] PROGMEM = "error: ";
  o.put_flash(kError);
  for (uint8_t i = 0; i < len; ++i) o.put(line[i]);
  if (axis >= 0) {
    o.put(':');
    o.put(' ');
    o.put(axis == 0 ? 'z' : axis == 1 ? 'y' : 'x');
    o.put_i32(target);
  }
  o.put_flash(reason(why));
  if (why == kCompErrLimit) {
    o.put_i32(lo);
    o.put('.');
    o.put('.');
    o.put_i32(hi);
  }
  out[o.n++] = '\n';
  return o.n;
}

}  // namespace fw
