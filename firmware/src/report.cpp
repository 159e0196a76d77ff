#include "report.h"

#include "clock.h"
#include "companion.h"
#include "fw_config.h"
#include "homing.h"
#include "scaratwin/protocol/codec_core.h"
#include "serial.h"
#include "servo.h"
#include "stepper.h"

namespace fw {
namespace {

namespace core = scaratwin::protocol::core;

uint16_t g_rate_hz = 0;
uint32_t g_period_us = 0;
uint32_t g_next_us = 0;
uint16_t g_seq = 0;
bool g_single_class = false;

}  // namespace

void report_set_rate(uint16_t rate_hz, uint32_t now_us) {
  g_rate_hz = rate_hz;
  g_period_us = rate_hz ? 1000000u / rate_hz : 0;
  g_next_us = now_us;
}

uint16_t report_rate() { return g_rate_hz; }

void report_set_single_class(bool on) { g_single_class = on; }

namespace {

bool send_report(uint8_t flags, uint8_t queue_free, uint8_t reserve) {
  const uint32_t t = clock_micros();
  int32_t pos[kNumAxes];
  stepper_positions(pos);
  const uint8_t endstops = stepper_endstops();
  char buf[kLineMax];
  core::Encoder enc(core::kSerialDeviceToHost, buf, sizeof buf);
  enc.begin(core::code_id('S', 'T'));
  enc.add_i32(g_seq);
  enc.add_u32(t);
  for (uint8_t i = 0; i < kNumAxes; ++i) enc.add_i32(pos[i]);
  enc.add_i32(servo_output_cdeg(kServoWrist));
  enc.add_i32(servo_output_cdeg(kServoGrip));
  enc.add_i32((int32_t)flags | ((int32_t)endstops << 5));
  enc.add_i32(queue_free);
  g_seq = (uint16_t)(g_seq + 1);
  if (!enc.end()) return false;
  if (serial_tx_free() < enc.size() + reserve) return false;  // lost: the gap shows it
  return serial_write(buf, (uint8_t)enc.size());
}

// The same sample as one line per value (companion.h); the number is used either way.
bool send_single_class(uint8_t reserve) {
  const uint32_t t = clock_micros();
  int32_t pos[kNumAxes];
  stepper_positions(pos);
  char buf[kCompanionReportMax];
  const uint8_t n =
      companion_report_lines(buf, sizeof buf, t, pos, homing_switch_counts(),
                             servo_output_cdeg(kServoWrist), servo_output_cdeg(kServoGrip));
  g_seq = (uint16_t)(g_seq + 1);
  if (n == 0 || serial_tx_free() < n + reserve) return false;  // lost: the t lines show it
  return serial_write(buf, n);
}

}  // namespace

bool report_now(uint8_t flags, uint8_t queue_free) {
  const uint32_t now = clock_micros();
  const bool sent = send_report(flags, queue_free, 0);
  // the answer stands in for the next periodic report: the grid restarts from it, so a QS
  // never leaves two reports back to back in the transmit buffer (the second one would not
  // fit while a trajectory's acknowledgements stream, and its number would be lost)
  if (sent && g_period_us != 0) g_next_us = now + g_period_us;
  return sent;
}

void report_poll(uint32_t now_us, uint8_t flags, uint8_t queue_free) {
  if (g_period_us == 0) return;
  int32_t late = (int32_t)(now_us - g_next_us);
  if (late < 0) return;
  uint32_t missed = (uint32_t)late / g_period_us;  // deadlines the loop did not see
  g_seq = (uint16_t)(g_seq + missed);
  g_next_us += (missed + 1) * g_period_us;
  if (g_single_class) {
    send_single_class(kReplyReserve);
  } else {
    send_report(flags, queue_free, kReplyReserve);
  }
}

}  // namespace fw
