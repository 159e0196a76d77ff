#include "serial.h"

#include <avr/interrupt.h>
#include <avr/io.h>

#include "board.h"

namespace fw {
namespace {

constexpr uint8_t kRxSize = 128;  // powers of two: index arithmetic with a mask
constexpr uint8_t kTxSize = 128;

volatile uint8_t g_rx[kRxSize];
volatile uint8_t g_rx_head = 0;  // written by the ISR
volatile uint8_t g_rx_tail = 0;  // written by the main loop
// A loss: the ring was full when a byte came. That line is dropped (the rest of it too), and
// so is every line after it until the reader reaches the place of the loss (the ring position
// of the first byte that did not fit), so that the reader learns of the lost lines in their
// place in the stream: g_loss_lines of them (saturating at 255), 0 when there is no loss.
volatile uint8_t g_loss_at = 0;
volatile uint8_t g_loss_lines = 0;
volatile bool g_rx_discarding = false;  // dropping the rest of a lost line
volatile uint8_t g_tx[kTxSize];
volatile uint8_t g_tx_head = 0;  // written by the main loop
volatile uint8_t g_tx_tail = 0;  // written by the ISR
RealtimeHandler g_on_realtime = nullptr;

}  // namespace

ISR(USART_RX_vect_NAME) {
  uint8_t b = UDR0;
  if (b == '!' || b == '#' || b == '~') {
    if (g_on_realtime) g_on_realtime(b);
    return;
  }
  if (g_rx_discarding) {
    if (b == '\n') g_rx_discarding = false;
    return;
  }
  if (g_loss_lines != 0) {
    // the reader has not reached the loss yet: this line is lost as well (an empty line is no
    // line: it gets no reply)
    if (b == '\n') return;
    if (g_loss_lines != 255) g_loss_lines = (uint8_t)(g_loss_lines + 1);
    g_rx_discarding = true;
    return;
  }
  uint8_t next = (uint8_t)((g_rx_head + 1) & (kRxSize - 1));
  if (next == g_rx_tail) {
    // full: this line is lost, the rest of it dropped up to its '\n'
    g_loss_at = g_rx_head;
    g_loss_lines = 1;
    g_rx_discarding = b != '\n';
    return;
  }
  g_rx[g_rx_head] = b;
  g_rx_head = next;
}

ISR(USART_UDRE_vect_NAME) {
  if (g_tx_head == g_tx_tail) {
    UCSR0B &= (uint8_t) ~(1 << UDRIE0);
    return;
  }
  UDR0 = g_tx[g_tx_tail];
  g_tx_tail = (uint8_t)((g_tx_tail + 1) & (kTxSize - 1));
}

void serial_set_baud(uint32_t baud) {
  // double speed (U2X) as the Arduino core does at 115200: 16 MHz / 8 / 17 = 117,647 baud
  uint16_t ubrr = (uint16_t)((F_CPU / 4 / baud - 1) / 2);
  UCSR0A = (1 << U2X0);
  UBRR0H = (uint8_t)(ubrr >> 8);
  UBRR0L = (uint8_t)ubrr;
}

bool serial_tx_empty() { return g_tx_head == g_tx_tail; }

void serial_init(uint32_t baud, RealtimeHandler on_realtime) {
  g_on_realtime = on_realtime;
  serial_set_baud(baud);
  UCSR0C = (1 << UCSZ01) | (1 << UCSZ00);
  UCSR0B = (1 << RXEN0) | (1 << TXEN0) | (1 << RXCIE0);
}

int16_t serial_read(uint8_t* lost_lines) {
  uint8_t tail = g_rx_tail;
  if (g_loss_lines != 0 && g_loss_at == tail) {
    // the lines lost here come before the byte stored here
    uint8_t sreg = SREG;
    cli();
    *lost_lines = g_loss_lines;
    g_loss_lines = 0;
    SREG = sreg;
    return kSerialLost;
  }
  if (tail == g_rx_head) return -1;
  uint8_t b = g_rx[tail];
  g_rx_tail = (uint8_t)((tail + 1) & (kRxSize - 1));
  return b;
}

int16_t serial_peek() {
  uint8_t tail = g_rx_tail;
  if (g_loss_lines != 0 && g_loss_at == tail) return kSerialLost;
  return tail == g_rx_head ? (int16_t)-1 : (int16_t)g_rx[tail];
}

bool serial_available() { return g_rx_tail != g_rx_head || g_loss_lines != 0; }

uint8_t serial_tx_free() { return (uint8_t)((g_tx_tail - g_tx_head - 1) & (kTxSize - 1)); }

bool serial_write(const char* data, uint8_t n) {
  if (n > serial_tx_free()) return false;
  uint8_t head = g_tx_head;
  for (uint8_t i = 0; i < n; ++i) {
    g_tx[head] = (uint8_t)data[i];
    head = (uint8_t)((head + 1) & (kTxSize - 1));
  }
  g_tx_head = head;
  UCSR0B |= (1 << UDRIE0);
  return true;
}

}  // namespace fw
