// Byte stream -> packets. The wire carries newline-terminated text packets ("JD,...,\n" on
// TCP, "ST=...=\n" on serial) and, on the TCP link, binary payloads behind a length header
// line ("IM,<nbytes>,\n" followed by exactly nbytes raw bytes). LineSplitter cuts a stream
// arriving in arbitrary chunks into those frames: any chunking of the same bytes gives the
// same frames. It is bounded: a line longer than `max_line_bytes` is cut, reported once as
// an overlong frame as soon as its length passes the limit (not only at its newline, so a
// peer that never sends one still hears of it), and the rest of it skipped up to the next
// newline (resync); a payload is
// never longer than `max_payload_bytes`. It does not decode fields; the protocol codec does.
// Pure: no I/O, no clock, no threads.
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <string>
#include <string_view>
#include <vector>

namespace scaratwin::transport {

enum class FrameKind {
  kLine,      // a text packet; `line` holds it without the '\n' (and without a final '\r')
  kBinary,    // a length-header line in `line` plus exactly the announced bytes in `payload`
  kOverlong,  // a line longer than the limit: `line` holds its first max_line_bytes bytes
  kOversize,  // a length header announcing more than max_payload_bytes: `line` holds the
              // header; the announced bytes were skipped (protocol error 12)
};

struct Frame {
  FrameKind kind = FrameKind::kLine;
  std::string line;
  std::vector<std::uint8_t> payload;
};

struct SplitterOptions {
  // Longest packet without its '\n' (and without a '\r' before it). The protocol limits
  // count the newline: 512 bytes on TCP (511 here), 96 on serial (95 here).
  std::size_t max_line_bytes = 511;
  // A complete line that is exactly `binary_prefix`, a decimal byte count n (at most 10
  // digits, n <= 2^31-1) and `binary_delimiter` announces n raw bytes that follow the
  // newline ("IM,15321,"). n above max_payload_bytes gives a kOversize frame and the n bytes
  // are skipped, keeping the stream in sync. Empty prefix: no binary payloads.
  std::string binary_prefix;
  char binary_delimiter = ',';
  std::size_t max_payload_bytes = std::size_t{8} << 20;  // 8 MiB
};

class LineSplitter {
 public:
  using Sink = std::function<void(Frame&&)>;

  explicit LineSplitter(SplitterOptions options = {});

  // Consumes `bytes` and calls `sink` for every frame completed by them, in order.
  // Empty lines ("\n" or "\r\n") are skipped.
  void feed(std::string_view bytes, const Sink& sink);

  // Forgets a partial line or payload (after a reconnect).
  void reset();

  // True while the splitter is inside a line or payload (bytes pending).
  bool mid_frame() const;

  const SplitterOptions& options() const { return options_; }

 private:
  void finish_line(const Sink& sink);
  // The payload size announced by a header line, or -1 when the line is not a header.
  long long binary_header_bytes(std::string_view line) const;

  SplitterOptions options_;
  std::string line_;
  bool overflow_ = false;
  bool discarding_ = false;  // an overlong line was reported: skip to its newline
  std::size_t payload_remaining_ = 0;
  bool skipping_ = false;  // the payload being consumed is oversize: drop it
  Frame pending_;          // the binary frame being filled
};

}  // namespace scaratwin::transport
