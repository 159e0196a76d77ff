// The paper's companion serial dialect (pure part: no hardware, built for the host's unit tests
// too). With setting 10 on, a line that starts with a lower-case letter is a companion line
// (a v1 packet starts with an upper-case code, so neither is ever read as the other):
//   z<steps>, y<steps>, x<steps>  absolute targets of the Z, J2 and J3 motors, in steps from
//                                 where each axis's switch closed when it homed (the companion
//                                 sketch's frame); a fraction is rounded to the nearest step;
//   m                             move all three to their targets together.
// A target beyond the joint limits (J3's with the coupling of the J2 target) is refused with
// an error line and moves nothing; so is a malformed or unknown line. docs/firmware.md has the
// reference; the controller does the moving.
#pragma once

#include <stdint.h>

#include "fw_config.h"

namespace fw {

constexpr uint8_t kCompanionLineMax = 24;  // longest companion line kept, without '\n'

enum CompanionKind : uint8_t {
  kCompanionTarget,   // z/y/x: *axis and *steps are set
  kCompanionMove,     // m
  kCompanionBadLine,  // a target whose number is malformed or beyond +-999,999,999
  kCompanionUnknown,  // a letter the dialect does not have, or m with something after it
};

// Parses one line without its "\r\n". axis: 0 Z (z), 1 J2 (y), 2 J3 (x).
CompanionKind companion_parse(const char* line, uint8_t len, uint8_t* axis, int32_t* steps);

// The targets (companion frame) that axis `axis` may take: zero[] are the motor counts of the
// companion frame's zero, j2_target the J2 target (companion frame; J3's motor range moves with
// it through the coupling). Limits from fw_config.h.
void companion_range(const int32_t zero[kNumAxes], int32_t j2_target, uint16_t coupling_permille,
                     uint8_t axis, int32_t* lo, int32_t* hi);

// Writes the error line for `line` into out (at most `cap` bytes, '\n' included) and returns
// its length: "error: <line> <reason>\n", the reason naming the valid range for a limit. An m
// refused for a target names it: axis >= 0 writes "error: m: <letter><target> <reason>\n".
enum CompanionError : uint8_t {
  kCompErrLimit,
  kCompErrBadNumber,
  kCompErrUnknown,
  kCompErrTooLong,
  kCompErrNotHomed,
  kCompErrBusy,
  kCompErrHalted
};
// The single-class report (setting 10 = 2): one sample of the robot as a sketch that sends one
// value per packet reports it, one line per value in a fixed order, each line named by its
// letter:
//   t<us>     the sample's time, micros() (the measuring instrument: the mixed ST has it too)
//   z<steps>  y<steps>  x<steps>   the Z, J2 and J3 motor counts in the companion frame (the
//                                  counts minus zero[]: the frame of the z/y/x lines)
//   w<cdeg>   g<cdeg>              the wrist and gripper servos' output
// Digits are made by subtracting powers of ten (no division: the AVR divides in software).
// Writes at most `cap` bytes and returns the length, 0 if the lines did not fit.
constexpr uint8_t kCompanionReportMax = 72;  // 6 lines of at most 12 bytes
uint8_t companion_report_lines(char* out, uint8_t cap, uint32_t t_us, const int32_t pos[kNumAxes],
                               const int32_t zero[kNumAxes], int32_t wrist_cdeg, int32_t grip_cdeg);

uint8_t companion_error_line(char* out, uint8_t cap, const char* line, uint8_t len,
                             CompanionError why, int32_t lo, int32_t hi, int8_t axis = -1,
                             int32_t target = 0);

}  // namespace fw
