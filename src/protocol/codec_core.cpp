// Packet codec core: streaming decoder and encoder (docs/protocol.md); the code tables are built
// from the packet structs' rows (link_tables.cpp; the firmware's are generated from them,
// firmware/tools/fw_codes.cpp). C++14 subset shared with the firmware: see codec_core.h.
#include "scaratwin/protocol/codec_core.h"

#include <string.h>

#if defined(__AVR__)
#include <avr/pgmspace.h>
#endif

namespace scaratwin {
namespace protocol {
namespace core {

const CodeSpec* find_code(const LinkSpec& link, uint16_t code) {
  for (uint8_t i = 0; i < link.code_count; ++i) {
    if (link.codes[i].code == code) return &link.codes[i];
  }
  return NULL;
}

const char* error_name(uint8_t code) {
  static const char* const kNames[kErrMaxCode + 1] = {
      "none",       "line_too_long", "bad_character",     "unknown_code", "wrong_field_count",
      "bad_number", "queue_full",    "not_homed",         "joint_limit",  "busy",
      "sequence",   "bad_value",     "payload_too_large", "version",      "halted",
      "internal",   "timeout",       "disconnected",      "access",       "no_robot"};
  return code <= kErrMaxCode ? kNames[code] : "unknown";
}

// character classes -------------------------------------------------------------------------

namespace {

inline bool is_digit(char c) { return c >= '0' && c <= '9'; }
inline bool is_upper(char c) { return c >= 'A' && c <= 'Z'; }
inline bool is_text_char(char c) {
  return (c >= 'a' && c <= 'z') || is_upper(c) || is_digit(c) || c == '_' || c == '.' || c == '-';
}
// A byte that may appear in a line at all: printable ASCII without space.
inline bool is_graphic(char c) {
  return static_cast<uint8_t>(c) > 0x20 && static_cast<uint8_t>(c) < 0x7f;
}

// 10^e for e <= 9. avr-gcc would put a table in RAM, so the AVR build multiplies.
inline uint32_t pow10_u32(uint8_t e) {
#ifdef __AVR__
  uint32_t v = 1;
  while (e-- > 0) v *= 10u;
  return v;
#else
  static const uint32_t kPow10[10] = {1u,      10u,      100u,      1000u,      10000u,
                                      100000u, 1000000u, 10000000u, 100000000u, 1000000000u};
  return kPow10[e];
#endif
}

// Checks a decimal field: ["-"] 1*DIGIT ["." 1*DIGIT], <= 9 significant integer digits and
// <= 6 fraction digits. When the value in millionths fits an int32_t, stores it in *micro
// and sets *fits.
bool check_decimal(const char* s, uint16_t n, int32_t* micro, bool* fits) {
  *fits = false;
  uint16_t i = 0;
  const bool negative = n > 0 && s[0] == '-';
  if (negative) i = 1;
  const uint16_t int_start = i;
  uint8_t significant = 0;
  uint32_t whole = 0;
  for (; i < n && is_digit(s[i]); ++i) {
    if (significant > 0 || s[i] != '0') {
      if (++significant > 9) return false;
    }
    whole = whole * 10u + static_cast<uint32_t>(s[i] - '0');
  }
  if (i == int_start) return false;
  uint32_t frac = 0;
  uint8_t frac_digits = 0;
  if (i < n) {
    if (s[i] != '.') return false;
    for (++i; i < n; ++i) {
      if (!is_digit(s[i]) || frac_digits == 6) return false;
      frac = frac * 10u + static_cast<uint32_t>(s[i] - '0');
      ++frac_digits;
    }
    if (frac_digits == 0) return false;
  }
  if (whole <= 2147u) {
    const uint32_t m =
        whole * pow10_u32(6) + frac * pow10_u32(static_cast<uint8_t>(6 - frac_digits));
    if (m <= 2147483647UL) {
      *micro = negative ? -static_cast<int32_t>(m) : static_cast<int32_t>(m);
      *fits = true;
    }
  }
  return true;
}

}  // namespace

// packet ------------------------------------------------------------------------------------

bool Packet::text_equals(uint8_t i, const char* s) const {
  const size_t n = strlen(s);
  return n == field_length[i] && memcmp(line + field_offset[i], s, n) == 0;
}

bool Packet::fixed(uint8_t i, uint8_t decimals, int32_t* out) const {
  if (i >= field_count || decimals > 9) return false;
  const char* s = text(i);
  const uint16_t n = field_length[i];
  uint16_t k = 0;
  bool negative = false;
  if (n > 0 && s[0] == '-') {
    negative = true;
    k = 1;
  }
  uint32_t acc = 0;
  for (; k < n && is_digit(s[k]); ++k) {
    const uint32_t d = static_cast<uint32_t>(s[k] - '0');
    if (acc > 429496729UL || (acc == 429496729UL && d > 5)) return false;
    acc = acc * 10u + d;
  }
  // integer part times 10^decimals, then the fraction digits, then rounding.
  if (acc > 4294967295UL / pow10_u32(decimals)) return false;
  acc *= pow10_u32(decimals);
  uint32_t frac = 0;
  uint8_t taken = 0;
  bool round_up = false;
  if (k < n && s[k] == '.') {
    for (++k; k < n && is_digit(s[k]); ++k) {
      if (taken < decimals) {
        frac = frac * 10u + static_cast<uint32_t>(s[k] - '0');
        ++taken;
      } else if (taken == decimals) {
        round_up = s[k] >= '5';
        ++taken;
      }
    }
  }
  for (; taken < decimals; ++taken) frac *= 10u;
  if (round_up) ++frac;
  if (acc > 4294967295UL - frac) return false;
  acc += frac;
  if (negative) {
    if (acc > 2147483648UL) return false;
    *out = static_cast<int32_t>(0u - acc);
  } else {
    if (acc > 2147483647UL) return false;
    *out = static_cast<int32_t>(acc);
  }
  return true;
}

// decoder -----------------------------------------------------------------------------------

Decoder::Decoder(const LinkSpec& link, char* buffer, uint16_t capacity)
    : link_(&link), buffer_(buffer), fill_(0), mode_(kLine), payload_left_(0) {
  const uint16_t by_link = link.max_line > 0 ? static_cast<uint16_t>(link.max_line - 1) : 0;
  limit_ = capacity < by_link ? capacity : by_link;
  memset(&packet_, 0, sizeof(packet_));
  packet_.line = buffer_;
}

void Decoder::reset() {
  fill_ = 0;
  mode_ = kLine;
  payload_left_ = 0;
}

bool Decoder::fail(Event* event, uint8_t error, int32_t detail, uint16_t code) {
  event->type = kEventError;
  event->error = error;
  event->detail = detail;
  event->code = code;
  return true;
}

size_t Decoder::feed(const uint8_t* data, size_t length, Event* event) {
  event->type = kEventNone;
  size_t pos = 0;
  while (pos < length) {
    if (mode_ == kPayload || mode_ == kSkipPayload) {
      size_t n = length - pos;
      if (n > payload_left_) n = static_cast<size_t>(payload_left_);
      payload_left_ -= static_cast<uint32_t>(n);
      const size_t start = pos;
      pos += n;
      const bool deliver = mode_ == kPayload;
      if (payload_left_ == 0) mode_ = kLine;
      if (deliver) {
        event->type = kEventPayload;
        event->payload = data + start;
        event->payload_length = n;
        event->payload_left = payload_left_;
        return pos;
      }
      continue;
    }
    if (link_->realtime) {
      // serial: byte by byte, real-time bytes are taken out wherever they occur.
      const char c = static_cast<char>(data[pos++]);
      if (c == kRealtimeStop || c == kRealtimeHold || c == kRealtimeResume) {
        event->type = kEventRealtime;
        event->realtime = c;
        return pos;
      }
      if (c == '\n') {
        if (mode_ == kDiscard) {
          mode_ = kLine;
          continue;
        }
        const uint16_t n = fill_;
        fill_ = 0;
        if (finish_line(buffer_, n, event)) return pos;
        continue;
      }
      if (mode_ == kDiscard) continue;
      if (fill_ >= limit_) {
        fill_ = 0;
        mode_ = kDiscard;
        fail(event, kErrLineTooLong, limit_ + 1, 0);
        return pos;
      }
      buffer_[fill_++] = c;
      continue;
    }
    // bulk: find the end of the line and copy up to it.
    const uint8_t* nl = static_cast<const uint8_t*>(memchr(data + pos, '\n', length - pos));
    const size_t end = nl ? static_cast<size_t>(nl - data) : length;
    if (mode_ == kDiscard) {
      pos = end;
      if (nl) {
        ++pos;
        mode_ = kLine;
      }
      continue;
    }
    const size_t chunk = end - pos;
    if (chunk > static_cast<size_t>(limit_ - fill_)) {
      fill_ = 0;
      if (nl) {
        pos = end + 1;
      } else {
        pos = length;
        mode_ = kDiscard;
      }
      fail(event, kErrLineTooLong, limit_ + 1, 0);
      return pos;
    }
    if (nl && fill_ == 0) {
      // the whole line is in the input: decode it in place.
      pos = end + 1;
      if (finish_line(reinterpret_cast<const char*>(data) + (end - chunk),
                      static_cast<uint16_t>(chunk), event)) {
        return pos;
      }
      continue;
    }
    memcpy(buffer_ + fill_, data + pos, chunk);
    fill_ = static_cast<uint16_t>(fill_ + chunk);
    pos = end;
    if (nl) {
      ++pos;
      const uint16_t n = fill_;
      fill_ = 0;
      if (finish_line(buffer_, n, event)) return pos;
    }
  }
  return pos;
}

bool Decoder::finish_line(const char* s, uint16_t n, Event* event) {
  if (n > 0 && s[n - 1] == '\r') --n;
  if (n == 0) return false;  // empty line: ignored
  validate(s, n, event);
  if (event->type == kEventPacket && (packet_.spec->flags & kCodeHasPayload)) {
    const int32_t bytes = packet_.value[0];
    if (bytes < 0) return fail(event, kErrBadNumber, 0, packet_.code);
    if (static_cast<uint32_t>(bytes) > link_->max_payload) {
      payload_left_ = static_cast<uint32_t>(bytes);
      mode_ = payload_left_ > 0 ? kSkipPayload : kLine;
      return fail(event, kErrPayloadTooLarge, static_cast<int32_t>(link_->max_payload),
                  packet_.code);
    }
    payload_left_ = static_cast<uint32_t>(bytes);
    mode_ = payload_left_ > 0 ? kPayload : kLine;
  }
  return true;
}

// Validates the line s[0, n) and fills packet_. Always produces an event; returns true.
bool Decoder::validate(const char* s, uint16_t n, Event* event) {
  const char delim = link_->delimiter;
  packet_.line = s;
  packet_.line_length = n;
  packet_.field_count = 0;
  packet_.micro_mask = 0;
  const uint16_t head = n < 3 ? n : 3;
  for (uint16_t i = 0; i < head; ++i) {
    if (!is_graphic(s[i])) return fail(event, kErrBadCharacter, i, 0);
  }
  if (n < 3 || !is_upper(s[0]) || !is_upper(s[1]) || s[2] != delim) {
    uint16_t bad = 0;
    if (is_upper(s[0])) bad = (n > 1 && is_upper(s[1])) ? 2 : 1;
    // a byte that can never be in a packet is reported first.
    for (uint16_t i = head; i < n; ++i) {
      if (!is_graphic(s[i])) return fail(event, kErrBadCharacter, i, 0);
    }
    return fail(event, kErrBadCharacter, bad, 0);
  }
  const uint16_t code = code_id(s[0], s[1]);
  const CodeSpec* spec = find_code(*link_, code);
  // split at the delimiters in one pass, checking for bytes that can never be in a packet
  // and parsing integer fields on the way (the hot path: joint-state packets).
  const uint8_t expected = spec != NULL ? spec->max_fields : 0;
  const uint8_t no_bad_int = 0xff;
  uint8_t bad_int = no_bad_int;  // first integer field that did not parse
  uint8_t count = 0;
  size_t i = 3;
  while (i < n) {
    const size_t start = i;
    const FieldKind kind = count < expected ? field_kind(*spec, count) : kFieldText;
    bool parsed = false;
    if (kind == kFieldI32 || kind == kFieldU32) {
      const bool negative = s[i] == '-';
      if (negative) ++i;
      const size_t digits_start = i;
      uint32_t acc = 0;
      bool overflow = false;
      for (; i < n; ++i) {
        const uint32_t d = static_cast<uint32_t>(static_cast<uint8_t>(s[i])) - '0';
        if (d > 9) break;
        if (acc > 429496729UL || (acc == 429496729UL && d > 5)) overflow = true;
        acc = acc * 10u + d;
      }
      if (i < n && s[i] == delim && i > digits_start && !overflow) {
        if (kind == kFieldU32) {
          parsed = !negative || acc == 0;
          packet_.value[count] = static_cast<int32_t>(acc);
        } else if (negative) {
          parsed = acc <= 2147483648UL;
          packet_.value[count] = static_cast<int32_t>(0u - acc);
        } else {
          parsed = acc <= 2147483647UL;
          packet_.value[count] = static_cast<int32_t>(acc);
        }
      }
      if (!parsed && bad_int == no_bad_int) bad_int = count;
    }
    for (; i < n; ++i) {
      const char c = s[i];
      if (c == delim) break;
      if (!is_graphic(c)) return fail(event, kErrBadCharacter, static_cast<int32_t>(i), 0);
    }
    if (i == n) break;  // no delimiter after the last field: reported below
    if (count < kMaxFields) {
      packet_.field_offset[count] = static_cast<uint16_t>(start);
      packet_.field_length[count] = static_cast<uint16_t>(i - start);
    }
    if (count < 255) ++count;
    ++i;
  }
  if (spec == NULL) return fail(event, kErrUnknownCode, 0, code);
  if (s[n - 1] != delim) return fail(event, kErrBadCharacter, n, code);
  packet_.field_count = count < kMaxFields ? count : kMaxFields;
  if (count < spec->min_fields || count > spec->max_fields) {
    return fail(event, kErrWrongFieldCount, count, code);
  }
  // the first bad field, in field order.
  for (uint8_t f = 0; f < count; ++f) {
    const FieldKind kind = field_kind(*spec, f);
    if (kind == kFieldI32 || kind == kFieldU32) {
      if (f == bad_int) return fail(event, kErrBadNumber, f, code);
      continue;
    }
    const char* field = s + packet_.field_offset[f];
    const uint16_t len = packet_.field_length[f];
    packet_.value[f] = 0;
    if (kind == kFieldDec) {
      bool fits = false;
      if (!check_decimal(field, len, &packet_.value[f], &fits)) {
        return fail(event, kErrBadNumber, f, code);
      }
      if (fits) packet_.micro_mask = static_cast<uint16_t>(packet_.micro_mask | (1u << f));
      continue;
    }
    if (len == 0 || len > kMaxTextLength) {
      const uint16_t at = len == 0 ? 0 : kMaxTextLength;
      return fail(event, kErrBadCharacter, packet_.field_offset[f] + at, code);
    }
    for (uint16_t k = 0; k < len; ++k) {
      if (!is_text_char(field[k])) {
        return fail(event, kErrBadCharacter, packet_.field_offset[f] + k, code);
      }
    }
  }
  packet_.code = code;
  packet_.spec = spec;
  event->type = kEventPacket;
  return true;
}

// encoder -----------------------------------------------------------------------------------

Encoder::Encoder(const LinkSpec& link, char* buffer, size_t capacity)
    : link_(&link),
      buffer_(buffer),
      capacity_(capacity),
      size_(0),
      packet_start_(0),
      code_(0),
      fields_(0),
      error_(kErrNone),
      packet_error_(kErrNone) {}

void Encoder::put(char c) {
  if (size_ >= capacity_) {
    if (packet_error_ == kErrNone) packet_error_ = kErrLineTooLong;
    return;
  }
  buffer_[size_++] = c;
}

#if defined(__AVR__)
namespace {
const uint32_t kPow10[10] PROGMEM = {1000000000u, 100000000u, 10000000u, 1000000u, 100000u,
                                     10000u,      1000u,      100u,      10u,      1u};
}  // namespace

// An 8-bit microcontroller divides in software (a 32-bit division by 10 costs ~600 cycles on
// an AVR, and a state report has ~40 digits): the digits come from the top, by subtracting
// powers of ten (at most 9 subtractions each), ~10x faster.
void Encoder::put_digits(uint32_t v, uint8_t min_digits) {
  bool started = false;
  for (uint8_t i = 0; i < 10; ++i) {
    const uint32_t p = pgm_read_dword(&kPow10[i]);
    char d = '0';
    while (v >= p) {
      v -= p;
      ++d;
    }
    if (d != '0' || started || 10u - i <= min_digits) {
      put(d);
      started = true;
    }
  }
}
#else
void Encoder::put_digits(uint32_t v, uint8_t min_digits) {
  char tmp[10];
  uint8_t n = 0;
  do {
    tmp[n++] = static_cast<char>('0' + static_cast<char>(v % 10u));
    v /= 10u;
  } while (v != 0 && n < 10);
  while (n < min_digits && n < 10) tmp[n++] = '0';
  while (n > 0) put(tmp[--n]);
}
#endif

void Encoder::begin(uint16_t code) {
  packet_start_ = size_;
  packet_error_ = kErrNone;
  code_ = code;
  fields_ = 0;
  put(static_cast<char>(code >> 8));
  put(static_cast<char>(code & 0xff));
  put(link_->delimiter);
}

void Encoder::start_field() {
  if (fields_ >= kMaxFields && packet_error_ == kErrNone) packet_error_ = kErrWrongFieldCount;
  ++fields_;
}

void Encoder::end_field() { put(link_->delimiter); }

void Encoder::add_i32(int32_t v) {
  start_field();
  if (v < 0) {
    put('-');
    put_digits(0u - static_cast<uint32_t>(v), 1);
  } else {
    put_digits(static_cast<uint32_t>(v), 1);
  }
  end_field();
}

void Encoder::add_u32(uint32_t v) {
  start_field();
  put_digits(v, 1);
  end_field();
}

void Encoder::add_fixed(int32_t scaled, uint8_t decimals) {
  start_field();
  if (decimals > 9) {
    if (packet_error_ == kErrNone) packet_error_ = kErrBadValue;
    return;
  }
  const uint32_t magnitude =
      scaled < 0 ? 0u - static_cast<uint32_t>(scaled) : static_cast<uint32_t>(scaled);
  const uint32_t whole = magnitude / pow10_u32(decimals);
  uint32_t frac = magnitude % pow10_u32(decimals);
  while (decimals > 0 && frac % 10u == 0) {
    frac /= 10u;
    --decimals;
  }
  if (scaled < 0) put('-');
  put_digits(whole, 1);
  if (decimals > 0) {
    put('.');
    put_digits(frac, decimals);
  }
  end_field();
}

void Encoder::add_text(const char* text, size_t length) {
  start_field();
  if (length == 0 || length > kMaxTextLength) {
    if (packet_error_ == kErrNone) packet_error_ = kErrBadValue;
    return;
  }
  for (size_t i = 0; i < length; ++i) {
    if (!is_text_char(text[i])) {
      if (packet_error_ == kErrNone) packet_error_ = kErrBadValue;
      return;
    }
    put(text[i]);
  }
  end_field();
}

void Encoder::add_text(const char* text) { add_text(text, strlen(text)); }

bool Encoder::end() {
  put('\n');
  if (packet_error_ == kErrNone) {
    const CodeSpec* spec = find_code(*link_, code_);
    if (spec == NULL) {
      packet_error_ = kErrUnknownCode;
    } else if (fields_ < spec->min_fields || fields_ > spec->max_fields) {
      packet_error_ = kErrWrongFieldCount;
    } else if (size_ - packet_start_ > link_->max_line) {
      packet_error_ = kErrLineTooLong;
    }
  }
  if (packet_error_ != kErrNone) {
    if (error_ == kErrNone) error_ = packet_error_;
    size_ = packet_start_;
    return false;
  }
  return true;
}

bool Encoder::add_raw(const uint8_t* data, size_t length) {
  if (length > capacity_ - size_) {
    if (error_ == kErrNone) error_ = kErrLineTooLong;
    return false;
  }
  memcpy(buffer_ + size_, data, length);
  size_ += length;
  return true;
}

}  // namespace core
}  // namespace protocol
}  // namespace scaratwin
