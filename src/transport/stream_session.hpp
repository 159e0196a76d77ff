// Internal: one live connection over an Asio stream (a TCP socket or a serial port): a read
// loop feeding the link, a write queue with a write timeout, and an optional idle timeout.
// It reports the end of the connection once, through `on_end`, and never after stop().
#pragma once

#include <utility>  // before Boost.Asio (Boost 1.74 misses it)

#include <array>
#include <boost/asio/steady_timer.hpp>
#include <boost/asio/write.hpp>
#include <chrono>
#include <deque>
#include <functional>
#include <memory>
#include <string>

#include "link_impl.hpp"

namespace scaratwin::transport::detail {

template <class Stream>
class StreamSession : public std::enable_shared_from_this<StreamSession<Stream>> {
 public:
  // `on_end(error)` runs on the io thread when the connection ends by itself (end of stream:
  // error false; I/O error or timeout: error true).
  StreamSession(std::shared_ptr<LinkImpl> link, Stream stream, std::uint32_t connection,
                std::function<void(bool error)> on_end)
      : link_(std::move(link)),
        stream_(std::move(stream)),
        connection_(connection),
        on_end_(std::move(on_end)),
        idle_timer_(link_->context()),
        write_timer_(link_->context()) {}

  void start() {
    last_rx_ = std::chrono::steady_clock::now();
    read();
    if (link_->options().idle_timeout.count() > 0) arm_idle(link_->options().idle_timeout);
  }

  void write(std::shared_ptr<std::string> bytes, std::uint64_t packets) {
    pending_.push_back(Pending{std::move(bytes), packets});
    if (!writing_) write_next();
  }

  // Closes the stream without calling on_end. Drops unwritten bytes from the accounting.
  void stop() {
    if (stopped_) return;
    stopped_ = true;
    on_end_ = nullptr;
    boost::system::error_code ignored;
    stream_.close(ignored);
    idle_timer_.cancel();
    write_timer_.cancel();
    std::size_t dropped = in_flight_bytes_;
    for (const auto& p : pending_) dropped += p.bytes->size();
    pending_.clear();
    in_flight_bytes_ = 0;
    link_->drop_tx(dropped);
    link_.reset();  // break the link -> session -> link cycle
  }

  bool stopped() const { return stopped_; }
  Stream& stream() { return stream_; }

 private:
  struct Pending {
    std::shared_ptr<std::string> bytes;
    std::uint64_t packets = 0;
  };

  void end(bool error) {
    if (stopped_) return;
    auto on_end = std::move(on_end_);
    stop();
    if (on_end) on_end(error);
  }

  void read() {
    stream_.async_read_some(
        boost::asio::buffer(buffer_),
        [self = this->shared_from_this()](const boost::system::error_code& ec, std::size_t n) {
          if (self->stopped_) return;
          if (n > 0) {
            self->last_rx_ = std::chrono::steady_clock::now();
            auto link = self->link_;  // on_bytes may run a handler that closes the link
            link->on_bytes(std::string_view(self->buffer_.data(), n), self->connection_);
            if (self->stopped_) return;  // a handler closed the link
          }
          if (ec) {
            self->end(ec != boost::asio::error::eof);
            return;
          }
          self->read();
        });
  }

  void write_next() {
    if (pending_.empty() || stopped_) return;
    // coalesce everything queued into one write
    auto batch = std::make_shared<std::string>();
    std::uint64_t packets = 0;
    if (pending_.size() == 1) {
      batch = std::move(pending_.front().bytes);
      packets = pending_.front().packets;
    } else {
      for (auto& p : pending_) {
        batch->append(*p.bytes);
        packets += p.packets;
      }
    }
    pending_.clear();
    writing_ = true;
    in_flight_bytes_ = batch->size();
    write_timer_.expires_after(link_->options().write_timeout);
    const std::uint64_t gen = ++write_gen_;
    write_timer_.async_wait(
        [self = this->shared_from_this(), gen](const boost::system::error_code& ec) {
          if (ec || self->stopped_ || !self->writing_ || gen != self->write_gen_) return;
          self->end(true);  // the peer stopped reading
        });
    boost::asio::async_write(stream_, boost::asio::buffer(*batch),
                             [self = this->shared_from_this(), batch, packets](
                                 const boost::system::error_code& ec, std::size_t n) {
                               if (self->stopped_) return;
                               self->write_timer_.cancel();
                               self->writing_ = false;
                               self->in_flight_bytes_ = 0;
                               if (ec) {
                                 self->link_->drop_tx(batch->size());
                                 self->end(true);
                                 return;
                               }
                               self->link_->count_written(n, packets);
                               self->write_next();
                             });
  }

  void arm_idle(std::chrono::steady_clock::duration after) {
    idle_timer_.expires_after(after);
    idle_timer_.async_wait([self = this->shared_from_this()](const boost::system::error_code& ec) {
      if (ec || self->stopped_) return;
      auto idle = self->link_->options().idle_timeout;
      auto quiet = std::chrono::steady_clock::now() - self->last_rx_;
      if (quiet >= idle) {
        self->end(true);
        return;
      }
      self->arm_idle(idle - quiet);
    });
  }

  std::shared_ptr<LinkImpl> link_;
  Stream stream_;
  std::uint32_t connection_;
  std::function<void(bool)> on_end_;
  boost::asio::steady_timer idle_timer_;
  boost::asio::steady_timer write_timer_;
  std::array<char, 65536> buffer_{};
  std::deque<Pending> pending_;
  bool writing_ = false;
  bool stopped_ = false;
  std::size_t in_flight_bytes_ = 0;
  std::uint64_t write_gen_ = 0;
  std::chrono::steady_clock::time_point last_rx_;
};

}  // namespace scaratwin::transport::detail
