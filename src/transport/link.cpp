#include <utility>  // before Boost.Asio (Boost 1.74 misses it)

#include <boost/asio/post.hpp>
#include <future>

#include "link_impl.hpp"

namespace scaratwin::transport {

namespace {
Error make_error(TransportError code, std::string message) {
  return Error{static_cast<int>(code), std::move(message)};
}
}  // namespace

std::int64_t steady_now_us() {
  return std::chrono::duration_cast<std::chrono::microseconds>(
             std::chrono::steady_clock::now().time_since_epoch())
      .count();
}

std::int64_t system_now_us() {
  return std::chrono::duration_cast<std::chrono::microseconds>(
             std::chrono::system_clock::now().time_since_epoch())
      .count();
}

const char* link_state_name(LinkState state) {
  switch (state) {
    case LinkState::kConnecting:
      return "connecting";
    case LinkState::kConnected:
      return "connected";
    case LinkState::kDisconnected:
      return "disconnected";
    case LinkState::kClosed:
      return "closed";
  }
  return "?";
}

std::uint32_t SequenceTracker::observe(std::uint16_t seq) {
  if (!started_) {
    started_ = true;
    expected_ = static_cast<std::uint16_t>(seq + 1);
    return 0;
  }
  auto gap = static_cast<std::uint16_t>(seq - expected_);
  if (gap >= 0x8000u) {  // behind what we expected: duplicate, reordering or a restart
    ++backwards_;
    expected_ = static_cast<std::uint16_t>(seq + 1);
    return 0;
  }
  expected_ = static_cast<std::uint16_t>(seq + 1);
  lost_ += gap;
  return gap;
}

namespace detail {

Error bad_option(std::string message) {
  return make_error(TransportError::kBadOption, std::move(message));
}

Status check_link_options(const LinkOptions& o, const std::string& who) {
  if (o.splitter.max_line_bytes == 0) return bad_option(who + ": max_line_bytes is 0, need >= 1");
  if (o.write_timeout.count() <= 0) {
    return bad_option(who + ": write_timeout " + std::to_string(o.write_timeout.count()) +
                      " ms, need > 0");
  }
  if (o.idle_timeout.count() < 0) {
    return bad_option(who + ": idle_timeout " + std::to_string(o.idle_timeout.count()) +
                      " ms, need >= 0 (0 = off)");
  }
  if (o.reconnect_min.count() <= 0 || o.reconnect_max < o.reconnect_min) {
    return bad_option(who + ": reconnect delays " + std::to_string(o.reconnect_min.count()) + ".." +
                      std::to_string(o.reconnect_max.count()) +
                      " ms, need 0 < reconnect_min <= reconnect_max");
  }
  if (o.max_rx_queue == 0) return bad_option(who + ": max_rx_queue is 0, need >= 1");
  return Ok{};
}

LinkImpl::LinkImpl(std::shared_ptr<IoThread> io, LinkOptions options, std::string name)
    : io_(io ? std::move(io) : IoThread::create()),
      options_(std::move(options)),
      name_(std::move(name)),
      splitter_(options_.splitter) {}

void LinkImpl::launch() {
  boost::asio::post(context(), [self = shared_from_this()] {
    if (!self->closed()) self->start();
  });
}

Status LinkImpl::send(std::string bytes, std::uint64_t packets) {
  if (closed_.load()) return make_error(TransportError::kClosed, name_ + " is closed");
  if (state_.load() != LinkState::kConnected) {
    return make_error(TransportError::kNotConnected,
                      name_ + " is " + link_state_name(state_.load()) + ", not connected");
  }
  const std::size_t n = bytes.size();
  const std::size_t queued = tx_queued_bytes_.fetch_add(n) + n;
  if (queued > options_.max_tx_queue_bytes) {
    tx_queued_bytes_ -= n;
    return make_error(TransportError::kBufferFull, name_ + ": " + std::to_string(queued) +
                                                       " bytes would be queued, limit " +
                                                       std::to_string(options_.max_tx_queue_bytes));
  }
  {
    std::lock_guard<std::mutex> lock(tx_mutex_);
    tx_pending_.emplace_back(std::make_shared<std::string>(std::move(bytes)), packets);
  }
  boost::asio::post(context(), [self = shared_from_this()] { self->drain_tx(); });
  return Ok{};
}

void LinkImpl::drain_tx() {
  std::deque<std::pair<std::shared_ptr<std::string>, std::uint64_t>> batch;
  {
    std::lock_guard<std::mutex> lock(tx_mutex_);
    batch.swap(tx_pending_);
  }
  for (auto& [data, packets] : batch) {
    if (closed() || !can_write()) {
      // the connection went away between send() and now
      drop_tx(data->size());
      count_error();
      continue;
    }
    write(data, packets);
  }
}

void LinkImpl::count_written(std::size_t bytes, std::uint64_t packets) {
  tx_queued_bytes_ -= bytes;
  bytes_out_ += bytes;
  packets_out_ += packets;
}

Result<RxPacket> LinkImpl::receive(Duration timeout) {
  std::unique_lock lock(mutex_);
  cv_.wait_for(lock, timeout, [&] { return !queue_.empty() || closed_.load(); });
  if (!queue_.empty()) {
    RxPacket p = std::move(queue_.front());
    queue_.pop_front();
    return p;
  }
  if (closed_.load()) return make_error(TransportError::kClosed, name_ + " is closed");
  return make_error(TransportError::kTimeout,
                    name_ + ": nothing received within " + std::to_string(timeout.count()) + " ms");
}

std::optional<RxPacket> LinkImpl::try_receive() {
  std::lock_guard lock(mutex_);
  if (queue_.empty()) return std::nullopt;
  RxPacket p = std::move(queue_.front());
  queue_.pop_front();
  return p;
}

std::size_t LinkImpl::clear_received() {
  std::lock_guard lock(mutex_);
  std::size_t n = queue_.size();
  queue_.clear();
  return n;
}

void LinkImpl::set_packet_handler(Link::PacketHandler handler) {
  std::lock_guard lock(mutex_);
  packet_handler_ = std::move(handler);
}

void LinkImpl::set_state_handler(Link::StateHandler handler) {
  std::lock_guard lock(mutex_);
  state_handler_ = std::move(handler);
}

Status LinkImpl::wait_connected(Duration timeout) {
  std::unique_lock lock(mutex_);
  cv_.wait_for(lock, timeout,
               [&] { return state_.load() == LinkState::kConnected || closed_.load(); });
  if (state_.load() == LinkState::kConnected) return Ok{};
  if (closed_.load()) return make_error(TransportError::kClosed, name_ + " is closed");
  return make_error(TransportError::kTimeout,
                    name_ + ": no connection within " + std::to_string(timeout.count()) + " ms");
}

LinkCounters LinkImpl::counters() const {
  LinkCounters c;
  c.packets_in = packets_in_.load();
  c.packets_out = packets_out_.load();
  c.bytes_in = bytes_in_.load();
  c.bytes_out = bytes_out_.load();
  c.errors = errors_.load();
  c.overlong = overlong_.load();
  c.connects = connects_.load();
  c.reconnects = c.connects > 0 ? c.connects - 1 : 0;
  c.disconnects = disconnects_.load();
  c.lost_packets = lost_packets_.load();
  c.rx_dropped = rx_dropped_.load();
  return c;
}

void LinkImpl::drop() {
  boost::asio::post(context(), [self = shared_from_this()] {
    if (!self->closed()) self->drop_connection();
  });
}

void LinkImpl::close() {
  if (closed_.exchange(true)) return;
  auto self = shared_from_this();
  auto finish = [self] {
    self->shutdown();
    self->set_state(LinkState::kClosed);
  };
  if (io_->in_io_thread()) {
    finish();
  } else {
    // shutdown() cancels every operation, which queues their handlers; two more rounds
    // through the queue let those run before close() returns
    std::promise<void> done;
    auto& ctx = context();
    boost::asio::post(ctx, [&] {
      finish();
      boost::asio::post(ctx, [&] { boost::asio::post(ctx, [&] { done.set_value(); }); });
    });
    done.get_future().wait();
  }
  cv_.notify_all();
}

void LinkImpl::set_state(LinkState state) {
  Link::StateHandler handler;
  {
    std::lock_guard lock(mutex_);
    if (state_.load() == state) return;
    if (state_.load() == LinkState::kClosed) return;
    state_ = state;
    handler = state_handler_;
  }
  cv_.notify_all();
  if (handler) {
    try {
      handler(state);
    } catch (...) {
      errors_++;
    }
  }
}

std::uint32_t LinkImpl::on_connected() {
  splitter_.reset();
  ++connection_;
  connects_++;
  reset_retry_delay();
  set_state(LinkState::kConnected);
  return connection_;
}

void LinkImpl::on_disconnected(bool error) {
  disconnects_++;
  if (error) errors_++;
  if (splitter_.mid_frame()) errors_++;  // a packet cut by the disconnection
  splitter_.reset();
  set_state(closed() ? LinkState::kClosed : LinkState::kDisconnected);
}

Duration LinkImpl::next_retry_delay() {
  retry_delay_ = retry_delay_.count() == 0 ? options_.reconnect_min
                                           : std::min(retry_delay_ * 2, options_.reconnect_max);
  return retry_delay_;
}

void LinkImpl::on_bytes(std::string_view bytes, std::uint32_t connection) {
  const std::int64_t steady_us = steady_now_us();
  const std::int64_t system_us = system_now_us();
  bytes_in_ += bytes.size();
  splitter_.feed(
      bytes, [&](Frame&& frame) { deliver(std::move(frame), steady_us, system_us, connection); });
}

void LinkImpl::deliver(Frame&& frame, std::int64_t steady_us, std::int64_t system_us,
                       std::uint32_t connection) {
  packets_in_++;
  if (frame.kind == FrameKind::kOverlong) {
    overlong_++;
    errors_++;
  } else if (frame.kind == FrameKind::kOversize) {
    errors_++;
  }
  RxPacket packet;
  packet.kind = frame.kind;
  packet.line = std::move(frame.line);
  packet.payload = std::move(frame.payload);
  packet.steady_us = steady_us;
  packet.system_us = system_us;
  packet.connection = connection;
  Link::PacketHandler handler;
  {
    std::lock_guard lock(mutex_);
    if (!packet_handler_) {
      if (queue_.size() >= options_.max_rx_queue) {
        queue_.pop_front();
        rx_dropped_++;
      }
      queue_.push_back(std::move(packet));
      cv_.notify_one();
      return;
    }
    handler = packet_handler_;
  }
  try {
    handler(std::move(packet));
  } catch (...) {
    errors_++;
  }
}

}  // namespace detail

// --- Link ----------------------------------------------------------------------------------

Link::Link(std::shared_ptr<detail::LinkImpl> impl) : impl_(std::move(impl)) {}

Link::~Link() {
  if (impl_) impl_->close();
}

std::string Link::name() const { return impl_->name(); }

Status Link::send(std::string bytes) {
  std::uint64_t packets = 0;
  for (char c : bytes) packets += c == '\n';
  return impl_->send(std::move(bytes), packets);
}

Status Link::send_binary(std::string_view header, std::span<const std::uint8_t> payload) {
  if (payload.size() > impl_->options().splitter.max_payload_bytes) {
    return make_error(TransportError::kPayloadTooLarge,
                      impl_->name() + ": payload of " + std::to_string(payload.size()) +
                          " bytes, limit " +
                          std::to_string(impl_->options().splitter.max_payload_bytes));
  }
  std::string bytes;
  bytes.reserve(header.size() + 1 + payload.size());
  bytes.append(header);
  bytes.push_back('\n');
  bytes.append(reinterpret_cast<const char*>(payload.data()), payload.size());
  return impl_->send(std::move(bytes), 1);
}

Result<RxPacket> Link::receive(Duration timeout) { return impl_->receive(timeout); }
std::optional<RxPacket> Link::try_receive() { return impl_->try_receive(); }
std::size_t Link::clear_received() { return impl_->clear_received(); }
void Link::set_packet_handler(PacketHandler handler) {
  impl_->set_packet_handler(std::move(handler));
}
void Link::set_state_handler(StateHandler handler) { impl_->set_state_handler(std::move(handler)); }
bool Link::connected() const { return impl_->state() == LinkState::kConnected; }
LinkState Link::state() const { return impl_->state(); }
Status Link::wait_connected(Duration timeout) { return impl_->wait_connected(timeout); }
LinkCounters Link::counters() const { return impl_->counters(); }
void Link::add_lost_packets(std::uint64_t n) { impl_->add_lost(n); }
void Link::add_error() { impl_->add_error(); }
void Link::drop() { impl_->drop(); }
void Link::close() { impl_->close(); }
IoThread& Link::io_thread() const { return impl_->io(); }

}  // namespace scaratwin::transport
