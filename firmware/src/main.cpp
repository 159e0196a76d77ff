// scaratwin firmware for the paper's desktop SCARA: an Arduino Uno (or Mega 2560) with a CNC
// shield v3 driving the Z, J2 and J3 steppers and the wrist and gripper servos. It speaks the
// physical-link protocol of docs/protocol.md over the USB serial port at 115200 baud.
// Copyright the scaratwin authors. Licensed under the Apache License, Version 2.0.
#include <avr/interrupt.h>
#include <avr/sleep.h>

#include "controller.h"

int main() {
  fw::controller_init();
  set_sleep_mode(SLEEP_MODE_IDLE);
  for (;;) {
    fw::controller_poll();
    // idle until the next interrupt (step tick, clock, serial) when nothing is pending
    cli();
    if (!fw::controller_busy()) {
      sleep_enable();
      sei();
      sleep_cpu();
      sleep_disable();
    }
    sei();
  }
}
