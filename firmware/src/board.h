// Board pin map. The firmware is wired like the authors' robot: an Arduino Uno (or Mega 2560)
// with a CNC shield v3. Stepper X drives Z, Y drives J2, Z drives J3; the endstops sit on the
// shield's X/Y/Z limit inputs; the wrist and gripper servos on A1 and A0; six jog buttons on
// the pins the shield leaves free. Each pin is written `LETTER, BIT` and used through the
// PIN_* macros below, so the rest of the firmware never names a port register.
//
//   signal        Uno pin  Uno port   Mega pin  Mega port
//   STEP Z/J2/J3  2/3/4    PD2/3/4    2/3/4     PE4/PE5/PG5
//   DIR Z/J2/J3   5/6/7    PD5/6/7    5/6/7     PE3/PH3/PH4
//   ENABLE (low)  8        PB0        8         PH5
//   ENDSTOP Z/J2/J3 9/10/11 PB1/2/3   9/10/11   PH6/PB4/PB5   (switch to GND, pull-up)
//   SERVO grip    A0       PC0        A0        PF0
//   SERVO wrist   A1       PC1        A1        PF1
//   JOG Z+ / Z-   A2/A3    PC2/PC3    A2/A3     PF2/PF3       (button to GND, pull-up)
//   JOG J2+ / J2- A4/A5    PC4/PC5    A4/A5     PF4/PF5
//   JOG J3+ / J3- 12/13    PB4/PB5    12/13     PB6/PB7
#pragma once

#include <avr/io.h>
#include <stdint.h>

#define FW_CAT(a, b) a##b
#define FW_PORT_(l, b) FW_CAT(PORT, l)
#define FW_DDR_(l, b) FW_CAT(DDR, l)
#define FW_PINR_(l, b) FW_CAT(PIN, l)
#define FW_BIT_(l, b) (b)
#define PIN_PORT(...) FW_PORT_(__VA_ARGS__)
#define PIN_DDR(...) FW_DDR_(__VA_ARGS__)
#define PIN_PINR(...) FW_PINR_(__VA_ARGS__)
#define PIN_BIT(...) FW_BIT_(__VA_ARGS__)
#define PIN_MASK(...) ((uint8_t)(1u << PIN_BIT(__VA_ARGS__)))
#define PIN_HIGH(...) (PIN_PORT(__VA_ARGS__) |= PIN_MASK(__VA_ARGS__))
#define PIN_LOW(...) (PIN_PORT(__VA_ARGS__) &= (uint8_t)~PIN_MASK(__VA_ARGS__))
#define PIN_READ(...) ((PIN_PINR(__VA_ARGS__) & PIN_MASK(__VA_ARGS__)) != 0)
#define PIN_OUTPUT(...) (PIN_DDR(__VA_ARGS__) |= PIN_MASK(__VA_ARGS__))
#define PIN_INPUT_PULLUP(...)                               \
  (PIN_DDR(__VA_ARGS__) &= (uint8_t)~PIN_MASK(__VA_ARGS__), \
   PIN_PORT(__VA_ARGS__) |= PIN_MASK(__VA_ARGS__))

#if defined(__AVR_ATmega328P__)
#define FW_BOARD_NAME "scara-uno"
#define USART_RX_vect_NAME USART_RX_vect
#define USART_UDRE_vect_NAME USART_UDRE_vect
#define PIN_STEP_Z D, 2
#define PIN_STEP_J2 D, 3
#define PIN_STEP_J3 D, 4
#define PIN_DIR_Z D, 5
#define PIN_DIR_J2 D, 6
#define PIN_DIR_J3 D, 7
#define PIN_ENABLE B, 0
#define PIN_ENDSTOP_Z B, 1
#define PIN_ENDSTOP_J2 B, 2
#define PIN_ENDSTOP_J3 B, 3
#define PIN_SERVO_GRIP C, 0
#define PIN_SERVO_WRIST C, 1
#define PIN_JOG_Z_POS C, 2
#define PIN_JOG_Z_NEG C, 3
#define PIN_JOG_J2_POS C, 4
#define PIN_JOG_J2_NEG C, 5
#define PIN_JOG_J3_POS B, 4
#define PIN_JOG_J3_NEG B, 5
#elif defined(__AVR_ATmega2560__)
#define FW_BOARD_NAME "scara-mega"
#define USART_RX_vect_NAME USART0_RX_vect
#define USART_UDRE_vect_NAME USART0_UDRE_vect
#define PIN_STEP_Z E, 4
#define PIN_STEP_J2 E, 5
#define PIN_STEP_J3 G, 5
#define PIN_DIR_Z E, 3
#define PIN_DIR_J2 H, 3
#define PIN_DIR_J3 H, 4
#define PIN_ENABLE H, 5
#define PIN_ENDSTOP_Z H, 6
#define PIN_ENDSTOP_J2 B, 4
#define PIN_ENDSTOP_J3 B, 5
#define PIN_SERVO_GRIP F, 0
#define PIN_SERVO_WRIST F, 1
#define PIN_JOG_Z_POS F, 2
#define PIN_JOG_Z_NEG F, 3
#define PIN_JOG_J2_POS F, 4
#define PIN_JOG_J2_NEG F, 5
#define PIN_JOG_J3_POS B, 6
#define PIN_JOG_J3_NEG B, 7
#else
#error "unsupported MCU: build for atmega328p (Uno) or atmega2560 (Mega 2560)"
#endif
