// Internal: the state every link shares (receive queue, handlers, counters, state) and the
// hooks its concrete kind (TCP client, TCP server, serial) implements on the io thread.
#pragma once

#include <utility>  // before Boost.Asio (Boost 1.74 misses it)

#include <atomic>
#include <boost/asio/io_context.hpp>
#include <condition_variable>
#include <deque>
#include <memory>
#include <mutex>
#include <string>

#include "scaratwin/transport/io_thread.hpp"
#include "scaratwin/transport/link.hpp"

namespace scaratwin::transport::detail {

Error bad_option(std::string message);
// Checks the options every link kind shares; `who` names the link in the message.
Status check_link_options(const LinkOptions& options, const std::string& who);

class LinkImpl : public std::enable_shared_from_this<LinkImpl> {
 public:
  LinkImpl(std::shared_ptr<IoThread> io, LinkOptions options, std::string name);
  virtual ~LinkImpl() = default;

  // --- any thread ---
  const std::string& name() const { return name_; }
  const LinkOptions& options() const { return options_; }
  boost::asio::io_context& context() { return io_->context(); }
  IoThread& io() { return *io_; }

  // Posts the kind's start() to the io thread.
  void launch();
  Status send(std::string bytes, std::uint64_t packets);
  Result<RxPacket> receive(Duration timeout);
  std::optional<RxPacket> try_receive();
  std::size_t clear_received();
  void set_packet_handler(Link::PacketHandler handler);
  void set_state_handler(Link::StateHandler handler);
  LinkState state() const { return state_.load(); }
  Status wait_connected(Duration timeout);
  LinkCounters counters() const;
  void add_lost(std::uint64_t n) { lost_packets_ += n; }
  void add_error() { errors_++; }
  // Posts drop_connection() to the io thread.
  void drop();
  // Closes on the io thread and waits until every handler of this link has run (unless
  // called on the io thread itself).
  void close();

  // --- io thread, for the kinds ---
  // Feeds received bytes of connection `connection` through the splitter and delivers frames.
  void on_bytes(std::string_view bytes, std::uint32_t connection);
  void set_state(LinkState state);
  // A connection came up: resets the splitter, counts it, sets kConnected.
  std::uint32_t on_connected();
  // The current connection ended (error or end of stream): counts it, sets kDisconnected.
  void on_disconnected(bool error);
  void count_error() { errors_++; }
  void count_written(std::size_t bytes, std::uint64_t packets);
  void drop_tx(std::size_t bytes) { tx_queued_bytes_ -= bytes; }
  bool closed() const { return closed_.load(); }
  // Delay before the next retry; doubles from reconnect_min up to reconnect_max.
  Duration next_retry_delay();
  void reset_retry_delay() { retry_delay_ = Duration{0}; }

 protected:
  // Before launch() only.
  void rename(std::string name) { name_ = std::move(name); }
  // io thread: begin connecting / opening / accepting.
  virtual void start() = 0;
  // io thread: write bytes on the current connection (the queue accounting is done).
  virtual void write(std::shared_ptr<std::string> bytes, std::uint64_t packets) = 0;
  // io thread: cancel every operation and close every socket or device. No callbacks after.
  virtual void shutdown() = 0;
  // io thread: true when a connection is up to write to.
  virtual bool can_write() const = 0;
  // io thread: end the current connection as failed (Link::drop); kinds that can reconnect.
  virtual void drop_connection() {}

 private:
  void deliver(Frame&& frame, std::int64_t steady_us, std::int64_t system_us,
               std::uint32_t connection);
  // io thread: writes everything send() queued, in the order send() was called.
  void drain_tx();

  std::shared_ptr<IoThread> io_;
  LinkOptions options_;
  std::string name_;
  LineSplitter splitter_;
  Duration retry_delay_{0};

  mutable std::mutex mutex_;
  std::condition_variable cv_;
  std::deque<RxPacket> queue_;
  Link::PacketHandler packet_handler_;
  Link::StateHandler state_handler_;

  std::atomic<LinkState> state_{LinkState::kConnecting};
  std::atomic<bool> closed_{false};
  std::atomic<std::size_t> tx_queued_bytes_{0};
  // Bytes handed to send() and not yet given to write(), in call order. Asio does not keep
  // handlers posted from different threads in posting order (a post from inside a handler
  // waits in the io thread's private queue until that handler returns), so the order of the
  // bytes is fixed here, under a mutex, and each posted drain takes whatever is queued.
  std::mutex tx_mutex_;
  std::deque<std::pair<std::shared_ptr<std::string>, std::uint64_t>> tx_pending_;
  std::uint32_t connection_ = 0;  // io thread only

  std::atomic<std::uint64_t> packets_in_{0}, packets_out_{0}, bytes_in_{0}, bytes_out_{0},
      errors_{0}, overlong_{0}, connects_{0}, disconnects_{0}, lost_packets_{0}, rx_dropped_{0};
};

}  // namespace scaratwin::transport::detail
