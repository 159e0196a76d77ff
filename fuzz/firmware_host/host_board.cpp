// The firmware built for the host: the registers of avr/io.h and the EEPROM of avr/eeprom.h.
// Compiled with fw_host_state.h first, so they are part of the firmware's state that each
// input starts from afresh.
#include "avr/eeprom.h"
#include "avr/io.h"

volatile uint8_t PORTB, PORTC, PORTD, DDRB, DDRC, DDRD;
// inputs idle high: released buttons and open switches (pull-ups)
volatile uint8_t PINB = 0xff, PINC = 0xff, PIND = 0xff;
volatile uint8_t SREG;
volatile uint8_t TCCR0A, TCCR0B, TCNT0, TIMSK0, TIFR0;
volatile uint8_t TCCR1A, TCCR1B, TIMSK1;
volatile uint16_t TCNT1, OCR1A;
volatile uint8_t TCCR2A, TCCR2B, TCNT2, OCR2A, TIMSK2, TIFR2;
volatile uint8_t UDR0, UCSR0A, UCSR0B, UCSR0C, UBRR0H, UBRR0L;

uint8_t fw_host_eeprom[1024] = {
#define FW_HOST_FF16 0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff, \
                     0xff, 0xff, 0xff, 0xff
#define FW_HOST_FF128 FW_HOST_FF16, FW_HOST_FF16, FW_HOST_FF16, FW_HOST_FF16, FW_HOST_FF16, \
                      FW_HOST_FF16, FW_HOST_FF16, FW_HOST_FF16
    FW_HOST_FF128, FW_HOST_FF128, FW_HOST_FF128, FW_HOST_FF128,
    FW_HOST_FF128, FW_HOST_FF128, FW_HOST_FF128, FW_HOST_FF128};
