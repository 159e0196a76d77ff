#include "scaratwin/transport/line_splitter.hpp"

#include <algorithm>
#include <cstring>
#include <utility>

namespace scaratwin::transport {

LineSplitter::LineSplitter(SplitterOptions options) : options_(std::move(options)) {
  line_.reserve(options_.max_line_bytes + 1);
}

void LineSplitter::reset() {
  line_.clear();
  overflow_ = false;
  discarding_ = false;
  payload_remaining_ = 0;
  skipping_ = false;
  pending_ = Frame{};
}

bool LineSplitter::mid_frame() const {
  return !line_.empty() || overflow_ || discarding_ || payload_remaining_ > 0;
}

long long LineSplitter::binary_header_bytes(std::string_view line) const {
  const std::string& prefix = options_.binary_prefix;
  if (prefix.empty() || line.size() <= prefix.size() || line.substr(0, prefix.size()) != prefix) {
    return -1;
  }
  std::string_view rest = line.substr(prefix.size());
  if (rest.size() < 2 || rest.size() > 11 || rest.back() != options_.binary_delimiter) return -1;
  long long n = 0;
  for (char c : rest.substr(0, rest.size() - 1)) {
    if (c < '0' || c > '9') return -1;
    n = n * 10 + (c - '0');
  }
  return n <= 2147483647LL ? n : -1;
}

void LineSplitter::finish_line(const Sink& sink) {
  if (!line_.empty() && line_.back() == '\r') line_.pop_back();
  if (overflow_ || line_.size() > options_.max_line_bytes) {
    Frame frame;
    frame.kind = FrameKind::kOverlong;
    frame.line = line_.substr(0, options_.max_line_bytes);
    line_.clear();
    overflow_ = false;
    sink(std::move(frame));
    return;
  }
  if (line_.empty()) return;
  if (long long n = binary_header_bytes(line_); n >= 0) {
    pending_ = Frame{};
    pending_.line = line_;
    line_.clear();
    const auto bytes = static_cast<std::size_t>(n);
    if (bytes > options_.max_payload_bytes) {
      pending_.kind = FrameKind::kOversize;
      skipping_ = true;
    } else {
      pending_.kind = FrameKind::kBinary;
      pending_.payload.reserve(bytes);
    }
    payload_remaining_ = bytes;
    if (bytes == 0) {
      Frame frame = std::move(pending_);
      pending_ = Frame{};
      sink(std::move(frame));
    }
    return;
  }
  Frame frame;
  frame.line = line_;
  line_.clear();
  sink(std::move(frame));
}

void LineSplitter::feed(std::string_view bytes, const Sink& sink) {
  const char* p = bytes.data();
  const char* end = p + bytes.size();
  while (p < end) {
    if (payload_remaining_ > 0) {
      std::size_t n = std::min(payload_remaining_, static_cast<std::size_t>(end - p));
      if (!skipping_) {
        pending_.payload.insert(pending_.payload.end(), reinterpret_cast<const std::uint8_t*>(p),
                                reinterpret_cast<const std::uint8_t*>(p + n));
      }
      p += n;
      payload_remaining_ -= n;
      if (payload_remaining_ == 0) {
        skipping_ = false;
        Frame frame = std::move(pending_);
        pending_ = Frame{};
        sink(std::move(frame));
      }
      continue;
    }
    const char* nl =
        static_cast<const char*>(std::memchr(p, '\n', static_cast<std::size_t>(end - p)));
    const char* stop = nl ? nl : end;
    if (discarding_) {
      // the rest of a line already reported as overlong
      p = nl ? nl + 1 : end;
      discarding_ = nl == nullptr;
      continue;
    }
    // keep at most max_line_bytes + 1 bytes (room for a final '\r'); beyond that only note
    // the overflow
    std::size_t room =
        options_.max_line_bytes + 1 - std::min(line_.size(), options_.max_line_bytes + 1);
    std::size_t take = std::min(room, static_cast<std::size_t>(stop - p));
    line_.append(p, take);
    if (take < static_cast<std::size_t>(stop - p)) overflow_ = true;
    p = stop;
    // overlong as soon as the limit is passed (a byte after max_line_bytes that is not the
    // final '\r'), not only at its newline: reported now, the rest skipped up to the newline
    const bool overlong =
        overflow_ || (line_.size() > options_.max_line_bytes && line_.back() != '\r');
    if (overlong) {
      Frame frame;
      frame.kind = FrameKind::kOverlong;
      frame.line = line_.substr(0, options_.max_line_bytes);
      line_.clear();
      overflow_ = false;
      discarding_ = nl == nullptr;
      if (nl) ++p;
      sink(std::move(frame));
      continue;
    }
    if (nl) {
      ++p;
      finish_line(sink);
    }
  }
}

}  // namespace scaratwin::transport
