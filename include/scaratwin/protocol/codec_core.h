// Packet codec core shared by the host and the Arduino firmware (docs/protocol.md).
//
// Packets are ASCII lines `ID<D>v1<D>v2<D>...\n`, with D = ',' on the virtual (TCP) link and
// D = '=' on the physical (serial) link. This file is the byte level only: a streaming
// decoder that splits, validates and parses packets against a per-link code table, and an
// encoder that writes packets into a fixed buffer. Typed messages in SI units live in the
// host layer (messages.hpp), which is built on top of this.
//
// Written in the C++14 subset that avr-gcc 5.4 compiles: no standard library headers (only
// <stdint.h>, <stddef.h>, <string.h>), no exceptions, no heap, no virtual functions, no
// floating point. Every buffer is owned and sized by the caller; nothing reads or writes
// past it. Note that on AVR `int` and `size_t` are 16 bits wide.
#ifndef SCARATWIN_PROTOCOL_CODEC_CORE_H_
#define SCARATWIN_PROTOCOL_CODEC_CORE_H_

#include <stddef.h>
#include <stdint.h>

namespace scaratwin {
namespace protocol {
namespace core {

// Protocol version carried by HI (docs/protocol.md section 11).
const int32_t kProtocolVersion = 1;
// Most fields in one packet.
const uint8_t kMaxFields = 12;
// Longest packet in bytes, including the terminating "\r\n" or "\n".
const uint16_t kSerialMaxLine = 96;
const uint16_t kTcpMaxLine = 512;
// Longest text field in characters.
const uint8_t kMaxTextLength = 32;
// Largest binary payload (IM image) on the TCP link, in bytes.
const uint32_t kMaxImageBytes = 8388608UL;
// Real-time bytes on the serial link (host -> device only), acted on at once.
const char kRealtimeStop = '!';
const char kRealtimeHold = '#';
const char kRealtimeResume = '~';

// Numbered error codes, one table for both links (docs/protocol.md section 6).
enum ErrorCode : uint8_t {
  kErrNone = 0,
  kErrLineTooLong = 1,
  kErrBadCharacter = 2,
  kErrUnknownCode = 3,
  kErrWrongFieldCount = 4,
  kErrBadNumber = 5,
  kErrQueueFull = 6,
  kErrNotHomed = 7,
  kErrJointLimit = 8,
  kErrBusy = 9,
  kErrSequence = 10,
  kErrBadValue = 11,
  kErrPayloadTooLarge = 12,
  kErrVersion = 13,
  kErrHalted = 14,
  kErrInternal = 15,
  kErrTimeout = 16,       // host-side only, never sent
  kErrDisconnected = 17,  // host-side only, never sent
  kErrAccess = 18,        // simulator link: connection refused (token, controller, observer)
  kErrNoRobot = 19,       // simulator link: the robot index names no robot (protocol v2)
};
const uint8_t kErrMaxCode = 19;
// Largest robot index of a robot-addressed TCP packet (protocol v2, docs/protocol.md 11.3).
const int32_t kMaxRobotIndex = 255;

// Short snake_case name of an error code ("line_too_long"), "unknown" for others.
const char* error_name(uint8_t code);

// Kind of one field (docs/protocol.md section 2).
enum FieldKind : uint8_t {
  kFieldI32 = 0,   // integer, -2147483648 .. 2147483647
  kFieldU32 = 1,   // integer, 0 .. 4294967295
  kFieldDec = 2,   // decimal, <= 9 significant digits before and <= 6 after the point
  kFieldText = 3,  // 1..32 characters of [A-Za-z0-9_.-]
};

// Two code letters as one number, for switch statements: code_id('J', 'D').
constexpr uint16_t code_id(char a, char b) {
  return static_cast<uint16_t>((static_cast<uint16_t>(static_cast<uint8_t>(a)) << 8) |
                               static_cast<uint8_t>(b));
}

// Flags of a code.
const uint8_t kCodeHasPayload = 1;  // field 0 is the length of a binary payload that follows

// One code of a link direction: its letters, field count range and field kinds.
struct CodeSpec {
  uint16_t code;       // code_id of the two letters
  uint8_t min_fields;  // fields beyond min_fields are optional (trailing)
  uint8_t max_fields;  // <= kMaxFields
  uint32_t kinds;      // FieldKind of field i in bits 2i..2i+1
  uint8_t flags;       // kCodeHasPayload
};

// FieldKind of field `index` of a code.
inline FieldKind field_kind(const CodeSpec& spec, uint8_t index) {
  return static_cast<FieldKind>((spec.kinds >> (2u * index)) & 3u);
}

// Builds a CodeSpec from a kind string: one letter per field, 'i' i32, 'u' u32, 'd' decimal,
// 't' text; max_fields is the string length. make_code('T','P', 6, "iiiiiii").
constexpr CodeSpec make_code(char a, char b, uint8_t min_fields, const char* kinds,
                             uint8_t flags = 0) {
  uint32_t mask = 0;
  uint8_t n = 0;
  while (kinds[n] != '\0' && n < kMaxFields) {
    const uint32_t k = kinds[n] == 'u' ? 1u : kinds[n] == 'd' ? 2u : kinds[n] == 't' ? 3u : 0u;
    mask |= k << (2u * n);
    ++n;
  }
  return CodeSpec{code_id(a, b), min_fields, n, mask, flags};
}

// One direction of one link: framing, limits and the codes the receiver accepts.
struct LinkSpec {
  char delimiter;        // '=' serial, ',' TCP
  uint8_t realtime;      // nonzero: '!', '#', '~' are real-time bytes, reported out of band
  uint16_t max_line;     // longest packet including "\r\n"
  uint32_t max_payload;  // largest binary payload in bytes (0: no payload codes)
  const CodeSpec* codes;
  uint8_t code_count;
};

// The four link directions of docs/protocol.md, named for the receiver's point of view.
extern const LinkSpec kSerialHostToDevice;  // firmware decodes this
extern const LinkSpec kSerialDeviceToHost;  // hub decodes this
extern const LinkSpec kTcpHubToSim;         // simulator decodes this
extern const LinkSpec kTcpSimToHub;         // hub decodes this

// The spec of `code` in `link`, or NULL when the link has no such code.
const CodeSpec* find_code(const LinkSpec& link, uint16_t code);

// A decoded packet: a view into the decoder's line buffer or into the bytes given to feed(),
// valid until the next feed() and while those bytes are.
// After a kEventError for a complete line, `line`, `line_length`, `field_count` (at most
// kMaxFields) and the field offsets and lengths describe the rejected line.
struct Packet {
  uint16_t code;         // code_id of the two letters
  const CodeSpec* spec;  // the code's entry in the link table
  uint8_t field_count;
  const char* line;  // the whole line without "\r\n" (not NUL-terminated)
  uint16_t line_length;
  uint16_t field_offset[kMaxFields];  // start of field i in `line`
  uint16_t field_length[kMaxFields];  // length of field i (without the delimiter)
  int32_t value[kMaxFields];          // parsed i32 fields; u32 fields as their bit pattern;
                                      // decimal fields in millionths when micro_mask says so
  uint16_t micro_mask;                // bit i: decimal field i is value[i] / 1e6 exactly

  int32_t i32(uint8_t i) const { return value[i]; }
  uint32_t u32(uint8_t i) const { return static_cast<uint32_t>(value[i]); }
  const char* text(uint8_t i) const { return line + field_offset[i]; }
  // True when field i is exactly the NUL-terminated string s.
  bool text_equals(uint8_t i, const char* s) const;
  // Field i (integer or decimal) scaled by 10^decimals and rounded half away from zero:
  // "12.345" with decimals 2 gives 1235. False when the result does not fit an int32_t or
  // decimals > 9.
  bool fixed(uint8_t i, uint8_t decimals, int32_t* out) const;
};

// What one feed() call produced.
enum EventType : uint8_t {
  kEventNone = 0,      // all input consumed, nothing complete yet
  kEventPacket = 1,    // a valid packet: Decoder::packet()
  kEventError = 2,     // a rejected line: error, detail, code
  kEventRealtime = 3,  // a real-time byte: realtime
  kEventPayload = 4,   // a chunk of binary payload: payload, payload_length
};

struct Event {
  uint8_t type;            // EventType
  uint8_t error;           // kEventError: ErrorCode
  int32_t detail;          // kEventError: detail of docs/protocol.md section 6
  uint16_t code;           // kEventError: code_id of the line when it was read, else 0
  char realtime;           // kEventRealtime: '!', '#' or '~'
  const uint8_t* payload;  // kEventPayload: chunk inside the bytes given to feed()
  size_t payload_length;   // kEventPayload: bytes in the chunk
  uint32_t payload_left;   // kEventPayload: payload bytes still to come after this chunk
};

// Streaming decoder for one link direction. Feeding the same bytes in any chunking gives the
// same events. A bad line gives one kEventError and decoding resumes after its '\n'.
class Decoder {
 public:
  // `buffer` holds one line; `capacity` bytes of it are used. A line longer than
  // min(capacity + 1, link.max_line) bytes (with its '\n') is kErrLineTooLong.
  Decoder(const LinkSpec& link, char* buffer, uint16_t capacity);

  // Consumes bytes until one event is complete or the input ends; returns the bytes consumed
  // (<= length) and fills *event (kEventNone when the input ran out first). Call again with
  // the rest of the input until it returns having consumed everything.
  size_t feed(const uint8_t* data, size_t length, Event* event);

  // One byte at a time (firmware receive loop); returns the event type.
  uint8_t push(uint8_t byte, Event* event) {
    feed(&byte, 1, event);
    return event->type;
  }

  // The last decoded packet (after kEventPacket).
  const Packet& packet() const { return packet_; }
  // Payload bytes still expected (after a packet of a kCodeHasPayload code).
  uint32_t payload_left() const { return payload_left_; }
  // Drops any partial line or payload (after a reconnect).
  void reset();

 private:
  enum Mode : uint8_t { kLine, kDiscard, kPayload, kSkipPayload };
  bool finish_line(const char* line, uint16_t n, Event* event);
  bool validate(const char* line, uint16_t n, Event* event);
  bool fail(Event* event, uint8_t error, int32_t detail, uint16_t code);

  const LinkSpec* link_;
  char* buffer_;
  uint16_t limit_;  // most bytes of a line before its '\n'
  uint16_t fill_;
  uint8_t mode_;
  uint32_t payload_left_;
  Packet packet_;
};

// Writes packets into a caller-owned buffer, several packets one after the other. A packet
// that does not fit, has a field the link does not allow or a bad text is rolled back and
// error() is set; earlier packets in the buffer stay.
class Encoder {
 public:
  // `link` is the receiver's direction (kSerialHostToDevice when the host sends to the
  // device): it gives the delimiter, the line limit and the field counts checked by end().
  Encoder(const LinkSpec& link, char* buffer, size_t capacity);

  void begin(uint16_t code);
  void add_i32(int32_t v);
  void add_u32(uint32_t v);
  // Writes scaled / 10^decimals with trailing zeros dropped: (12500, 3) -> "12.5".
  void add_fixed(int32_t scaled, uint8_t decimals);
  // Text of [A-Za-z0-9_.-], 1..32 characters.
  void add_text(const char* text, size_t length);
  void add_text(const char* text);
  // Appends '\n'. Returns false (and rolls the packet back) on any error since begin().
  bool end();

  // Appends raw bytes (an IM payload) after a packet.
  bool add_raw(const uint8_t* data, size_t length);

  size_t size() const { return size_; }
  const char* data() const { return buffer_; }
  // First error since construction or clear(): kErrLineTooLong (no room), kErrBadValue
  // (bad text or too many fields), kErrWrongFieldCount, kErrUnknownCode.
  uint8_t error() const { return error_; }
  void clear() {
    size_ = 0;
    error_ = kErrNone;
    packet_error_ = kErrNone;
  }

 private:
  void put(char c);
  void put_digits(uint32_t v, uint8_t min_digits);
  void start_field();
  void end_field();

  const LinkSpec* link_;
  char* buffer_;
  size_t capacity_;
  size_t size_;
  size_t packet_start_;
  uint16_t code_;
  uint8_t fields_;
  uint8_t error_;
  uint8_t packet_error_;
};

}  // namespace core
}  // namespace protocol
}  // namespace scaratwin

#endif  // SCARATWIN_PROTOCOL_CODEC_CORE_H_
