// A link: one bidirectional packet connection (TCP client, TCP server, serial port) whose I/O
// runs on an io thread (see io_thread.hpp). Every link offers the same thread-safe API: send
// bytes (pre-encoded packets), receive frames with their receive timestamps (from a queue or
// through a callback on the io thread), wait for the connection, watch state changes, and read
// per-link counters. Links detect disconnection (end of stream, I/O error, optional idle
// timeout) and re-establish themselves where that makes sense (a TCP client reconnects, a
// serial port reopens its device path, a TCP server accepts the next peer).
//
// Timestamps are microseconds: `steady_us` on std::chrono::steady_clock (for latencies and
// intervals), `system_us` on the system clock since the Unix epoch (for logs and databases).
#pragma once

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "scaratwin/core/result.hpp"
#include "scaratwin/transport/line_splitter.hpp"

namespace scaratwin::transport {

using Duration = std::chrono::milliseconds;

// Error codes of the transport: TransportError (scaratwin/core/error_codes.hpp, 100..119),
// disjoint from the protocol's codes (200 + the wire code).

std::int64_t steady_now_us();
std::int64_t system_now_us();

// One received packet and when it arrived.
struct RxPacket {
  FrameKind kind = FrameKind::kLine;
  std::string line;                   // packet text without '\n' (binary: the header line)
  std::vector<std::uint8_t> payload;  // binary payload (kBinary only)
  std::int64_t steady_us = 0;         // steady clock when the read that completed it returned
  std::int64_t system_us = 0;         // system clock, us since 1970-01-01 UTC, same instant
  std::uint32_t connection = 0;       // which connection (1, 2, ...) of the link it came from
};

// Per-link counters (a snapshot; the live counters are atomics).
struct LinkCounters {
  std::uint64_t packets_in = 0;   // frames received (lines, binary frames, overlong lines)
  std::uint64_t packets_out = 0;  // packets written ('\n' in sent bytes, +1 per payload)
  std::uint64_t bytes_in = 0;
  std::uint64_t bytes_out = 0;
  std::uint64_t errors = 0;        // I/O errors and timeouts, overlong lines, oversize payloads,
                                   // handler failures, decode errors (add_error)
  std::uint64_t overlong = 0;      // of which overlong lines
  std::uint64_t connects = 0;      // connections established (first one included)
  std::uint64_t reconnects = 0;    // connections established after a loss (connects - 1)
  std::uint64_t disconnects = 0;   // connections lost or dropped
  std::uint64_t lost_packets = 0;  // sequence gaps, reported by the message layer
  std::uint64_t rx_dropped = 0;    // received frames dropped because the queue was full
};

enum class LinkState { kConnecting, kConnected, kDisconnected, kClosed };
const char* link_state_name(LinkState state);

// Options shared by every link.
struct LinkOptions {
  SplitterOptions splitter;          // line limit and binary framing
  Duration idle_timeout{0};          // no byte for this long = link dead; 0 = off
  Duration write_timeout{2000};      // a write stuck this long = link dead
  std::size_t max_rx_queue = 65536;  // frames kept for receive(); oldest dropped beyond
  std::size_t max_tx_queue_bytes = std::size_t{16} << 20;  // pending output bytes
  bool auto_reconnect = true;    // reconnect / reopen / accept again after a loss
  Duration reconnect_min{50};    // first retry delay; doubles per failure
  Duration reconnect_max{1000};  // longest retry delay
};

class IoThread;
namespace detail {
class LinkImpl;
}

class Link {
 public:
  // Called on the io thread for each received packet (instead of queueing it). Must not block
  // for long; exceptions are caught and counted as errors.
  using PacketHandler = std::function<void(RxPacket&&)>;
  // Called on the io thread on every state change.
  using StateHandler = std::function<void(LinkState)>;

  Link(const Link&) = delete;
  Link& operator=(const Link&) = delete;
  virtual ~Link();  // closes the link and waits for its handlers to finish

  // Human-readable description, e.g. "tcp-client 127.0.0.1:55016" or "serial /dev/ttyACM0".
  std::string name() const;

  // Queues pre-encoded bytes for writing (one or several packets, each ending in '\n', or a
  // real-time byte). Fails with kNotConnected, kClosed or kBufferFull; never blocks.
  Status send(std::string bytes);
  // Sends a length-header line (e.g. "IM,1234,") and exactly the payload bytes after it.
  // The header must not contain the newline; it is added.
  Status send_binary(std::string_view header, std::span<const std::uint8_t> payload);

  // Oldest received packet, waiting up to `timeout`: kTimeout if none came, kClosed after
  // close(). Packets are only queued while no packet handler is set.
  Result<RxPacket> receive(Duration timeout);
  std::optional<RxPacket> try_receive();
  // Drops every queued packet; returns how many.
  std::size_t clear_received();

  void set_packet_handler(PacketHandler handler);
  void set_state_handler(StateHandler handler);

  bool connected() const;
  LinkState state() const;
  // Waits until the link is connected (kTimeout otherwise; kClosed after close()).
  Status wait_connected(Duration timeout);

  LinkCounters counters() const;
  // The message layer reports packets it found missing (sequence gaps).
  void add_lost_packets(std::uint64_t n);
  // The message layer reports a packet it could not decode.
  void add_error();

  // Ends the current connection as failed, as an I/O error would (the layer above found the
  // peer no longer answering): counted as a disconnect and an error; a TCP client then
  // reconnects by itself. No effect on a link without a connection, or on a server.
  void drop();

  // Stops all I/O, drops the connection, wakes every waiter. Idempotent.
  void close();

  // The io thread this link runs on (to run more work there, e.g. timers of a layer above).
  IoThread& io_thread() const;

 protected:
  explicit Link(std::shared_ptr<detail::LinkImpl> impl);
  std::shared_ptr<detail::LinkImpl> impl_;
};

// Follows 16-bit wrapping sequence numbers (the ST and JD packets) and counts the gaps.
class SequenceTracker {
 public:
  // Number of packets missing before `seq` (0 for the first packet and for an in-order one).
  // A step backwards (duplicate, reordering, peer restart) counts nothing and resynchronises.
  std::uint32_t observe(std::uint16_t seq);
  std::uint64_t lost() const { return lost_; }
  std::uint64_t backwards() const { return backwards_; }
  void reset() { started_ = false; }

 private:
  bool started_ = false;
  std::uint16_t expected_ = 0;
  std::uint64_t lost_ = 0;
  std::uint64_t backwards_ = 0;
};

}  // namespace scaratwin::transport
