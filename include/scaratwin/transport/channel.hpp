// A typed request/reply channel over a link: the message layer between the transports and
// the control statements. It encodes protocol messages (scaratwin/protocol/codec.hpp), sends
// them, decodes what arrives, and matches replies to requests: every line a peer receives
// gets exactly one reply, in order (docs/protocol.md section 5), so pending requests form a
// FIFO; an `OP` request collects its `OP` packets up to the closing `AK`. Packets that answer
// nothing (EV, JW, periodic ST, an unsolicited HI after a reset) go to the unsolicited
// handler. State reports (ST) feed the link's lost-packet counter through their sequence
// numbers; lines that do not decode count as link errors.
//
// On the serial link the channel keeps the bytes of unanswered lines at or below the
// device's 64-byte receive window (grbl's character counting), queueing requests until
// replies make room. A request that times out stays in the FIFO so later replies still line
// up; when a reply matches a later request, timed-out ones before it are dropped (resync).
// When the link drops, every pending request fails with kErrDisconnected.
//
// Errors of request()/post(): Error::code is protocol_error_code(ErrorCode) (200 + the peer's
// ER code 1..15, 200 + 16 kErrTimeout, 200 + 17 kErrDisconnected) or a TransportError (100..119)
// for a local failure (scaratwin/core/error_codes.hpp).
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "scaratwin/core/result.hpp"
#include "scaratwin/protocol/codec.hpp"
#include "scaratwin/protocol/messages.hpp"
#include "scaratwin/transport/link.hpp"

namespace scaratwin::transport {

struct ChannelOptions {
  // Bytes of sent but unanswered lines the peer can buffer; 0 = unlimited (TCP).
  std::size_t window_bytes = 0;
  // Liveness (a peer that hangs without closing its connection): with heartbeat > 0 the
  // channel pings (PI) whenever nothing it sent has been waiting for a reply for `heartbeat`,
  // and ends the connection (Link::drop, kErrDisconnected for every pending request) when the
  // oldest unanswered request has waited `dead_after` and no byte came meanwhile. A request
  // whose code is in `slow_codes` (a camera shot) may take its own timeout instead.
  Duration heartbeat{0};
  Duration dead_after{1000};
  std::vector<std::string> slow_codes;
};
inline constexpr std::size_t kSerialWindowBytes = 64;

template <class Out, class In>
class Channel {
 public:
  // The reply to one request, with the times it was sent and its (last) packet received.
  struct Reply {
    std::vector<In> messages;  // one message; for an OP request the OP packets then the AK
    std::int64_t sent_steady_us = 0;
    std::int64_t rx_steady_us = 0;
    std::int64_t rx_system_us = 0;
    const In& last() const { return messages.back(); }
  };
  // Runs on the io thread; must not block.
  using ReplyHandler = std::function<void(Result<Reply>&&)>;
  using UnsolicitedHandler = std::function<void(In&&, const RxPacket&)>;

  // Takes over `link`'s packet and state handlers until destroyed. `link` must outlive it.
  explicit Channel(Link& link, ChannelOptions options = {});
  ~Channel();
  Channel(const Channel&) = delete;
  Channel& operator=(const Channel&) = delete;

  // Sends `message` and waits up to `timeout` for its reply. An ER reply is returned as an
  // Error with the peer's code and a message naming the request.
  Result<Reply> request(const Out& message, Duration timeout);
  // Sends `message` without waiting; `on_reply` (optional, io thread) gets the reply or the
  // error; the reply is consumed either way. `timeout` bounds the wait for the reply.
  Status post(const Out& message, ReplyHandler on_reply = nullptr,
              Duration timeout = Duration{2000});
  // Serial only: a real-time byte ('!', '#', '~'): sent at once, ahead of queued requests,
  // outside the window; no reply.
  Status send_realtime(protocol::Realtime command);

  // Fails every request waiting for a reply or for the window with kErrDisconnected and
  // `why`, at once (the layer above found the link silent). Sent requests stay in line,
  // abandoned, so that late replies are still matched by their codes (as after a timeout).
  void fail_pending(const std::string& why);

  // Forgets the sent requests that timed out and still wait in line for a late reply. After
  // the peer restarted (a board resets when its port opens, and its bootloader takes the first
  // bytes as its own), their replies never come, and every later reply of the same code would
  // be taken for the oldest of them instead of for the request it answers.
  void forget_abandoned();

  void set_unsolicited_handler(UnsolicitedHandler handler);
  // Link state changes, forwarded (the channel itself uses the link's state handler).
  void set_state_handler(Link::StateHandler handler);

  // Requests sent and not answered, and requests waiting for the window.
  std::size_t in_flight() const;
  std::size_t queued() const;
  // Lines that did not decode (also counted in the link's errors) and the last such error.
  std::uint64_t decode_errors() const;
  std::string last_decode_error() const;
  // ST sequence-gap tracking of this channel.
  std::uint64_t lost_packets() const;
  // Connections the heartbeat ended (the peer stopped answering), and why the last one was
  // ended (empty while the connection in place was not ended that way).
  std::uint64_t heartbeat_drops() const;
  std::string last_drop_reason() const;

  Link& link() { return link_; }

  struct State;

 private:
  Link& link_;
  std::shared_ptr<State> state_;
};

// Host <-> robot firmware (serial framing, 64-byte window).
using RobotChannel = Channel<protocol::SerialToDevice, protocol::SerialFromDevice>;
// Hub <-> simulator (TCP framing).
using SimChannel = Channel<protocol::TcpToSim, protocol::TcpFromSim>;

inline ChannelOptions robot_channel_defaults() {
  ChannelOptions o;
  o.window_bytes = kSerialWindowBytes;
  return o;
}

}  // namespace scaratwin::transport
