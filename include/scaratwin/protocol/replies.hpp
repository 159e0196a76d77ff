// Which packet answers which request (docs/protocol.md sections 7 and 8, the tables' "reply"
// column): one table per link, built from the requests' rows (their `kReply`, messages.hpp).
// The channel (scaratwin/transport/channel.hpp) matches each
// packet it receives to the oldest request it answers with reply_match(); the docs test
// (tests/protocol/test_docs_tables.cpp) checks the tables against the docs. Two rules hold on
// every link and are not rows: an `ER` answers the oldest request, and an `AK` answers the
// request whose code it carries. Pure: no I/O, no threads, no clock.
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <string_view>

#include "scaratwin/protocol/messages.hpp"

namespace scaratwin::protocol {

enum class ReplyMatch : std::uint8_t {
  kNo,       // not an answer to this request
  kPartial,  // one of several answers; the final one follows (OP ... then AK,OP)
  kFinal,    // the answer: the request is done
};

// A packet that answers a request, beside the two rules above.
struct ReplyRule {
  std::string_view request;  // the request's code
  std::string_view reply;    // the code of a packet that answers it
  bool partial = false;      // ReplyMatch::kPartial, else kFinal
  bool same_seq = false;     // only the request with the reply's sequence number (JA: JD, TJ)
};

// The rows of each link: hub -> simulator requests answered by the simulator, host -> device
// requests answered by the device.
std::span<const ReplyRule> tcp_reply_rules();
std::span<const ReplyRule> serial_reply_rules();

// The two-letter code of a received packet.
std::string_view code_of(const TcpFromSim& message);
std::string_view code_of(const SerialFromDevice& message);

// Whether `message` answers the request with code `request` (and sequence number `seq`, for
// JD and TJ).
ReplyMatch reply_match(std::string_view request, std::optional<std::uint16_t> seq,
                       const TcpFromSim& message);
ReplyMatch reply_match(std::string_view request, std::optional<std::uint16_t> seq,
                       const SerialFromDevice& message);

}  // namespace scaratwin::protocol
