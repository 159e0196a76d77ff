// The firmware built for the host (the command-handling fuzzer and its corpus replay): the
// ATmega328P's registers the firmware touches, as plain memory the harness reads and writes
// (firmware_host.cpp). Bit numbers as in avr-libc's iom328p.h.
#pragma once

#include <stdint.h>

#define FW_HOST_REG8(name) extern volatile uint8_t name
#define FW_HOST_REG16(name) extern volatile uint16_t name

FW_HOST_REG8(PORTB);
FW_HOST_REG8(PORTC);
FW_HOST_REG8(PORTD);
FW_HOST_REG8(DDRB);
FW_HOST_REG8(DDRC);
FW_HOST_REG8(DDRD);
FW_HOST_REG8(PINB);
FW_HOST_REG8(PINC);
FW_HOST_REG8(PIND);
FW_HOST_REG8(SREG);
FW_HOST_REG8(TCCR0A);
FW_HOST_REG8(TCCR0B);
FW_HOST_REG8(TCNT0);
FW_HOST_REG8(TIMSK0);
FW_HOST_REG8(TIFR0);
FW_HOST_REG8(TCCR1A);
FW_HOST_REG8(TCCR1B);
FW_HOST_REG16(TCNT1);
FW_HOST_REG16(OCR1A);
FW_HOST_REG8(TIMSK1);
FW_HOST_REG8(TCCR2A);
FW_HOST_REG8(TCCR2B);
FW_HOST_REG8(TCNT2);
FW_HOST_REG8(OCR2A);
FW_HOST_REG8(TIMSK2);
FW_HOST_REG8(TIFR2);
FW_HOST_REG8(UDR0);
FW_HOST_REG8(UCSR0A);
FW_HOST_REG8(UCSR0B);
FW_HOST_REG8(UCSR0C);
FW_HOST_REG8(UBRR0H);
FW_HOST_REG8(UBRR0L);

#define CS00 0
#define CS01 1
#define CS11 1
#define CS21 1
#define TOIE0 0
#define TOV0 0
#define OCIE1A 1
#define OCIE2A 1
#define OCF2A 1
#define WGM21 1
#define U2X0 1
#define UCSZ00 1
#define UCSZ01 2
#define TXEN0 3
#define RXEN0 4
#define UDRIE0 5
#define RXCIE0 7
