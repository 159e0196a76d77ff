#include <utility>  // before Boost.Asio (Boost 1.74 misses it)

#include "scaratwin/transport/channel.hpp"

#include <algorithm>
#include <boost/asio/post.hpp>
#include <boost/asio/steady_timer.hpp>
#include <condition_variable>
#include <deque>
#include <future>
#include <mutex>
#include <optional>
#include <string>

#include "scaratwin/protocol/replies.hpp"
#include "scaratwin/transport/io_thread.hpp"

namespace scaratwin::transport {

namespace {

using namespace protocol;

Error proto_error(std::int32_t code, std::string message) {
  return Error{protocol_error_code(code), std::move(message)};
}

std::optional<std::uint16_t> seq_of(const TcpToSim& m) {
  if (const auto* jd = std::get_if<JointData>(&m)) return jd->seq;
  if (const auto* tj = std::get_if<JointTargets>(&m)) return tj->seq;
  return std::nullopt;
}
std::optional<std::uint16_t> seq_of(const SerialToDevice&) { return std::nullopt; }

std::optional<std::uint16_t> state_seq(const TcpFromSim& m) {
  if (const auto* st = std::get_if<SimState>(&m)) return st->seq;
  return std::nullopt;
}
std::optional<std::uint16_t> state_seq(const SerialFromDevice& m) {
  if (const auto* st = std::get_if<DeviceState>(&m)) return st->seq;
  return std::nullopt;
}

}  // namespace

template <class Out, class In>
struct Channel<Out, In>::State {
  struct Entry {
    std::string code;
    std::optional<std::uint16_t> seq;
    std::string bytes;
    Reply reply;
    ReplyHandler handler;
    std::int64_t deadline_us = 0;
    std::int64_t allowance_us = 0;  // how long it may wait before the peer counts as hung
    bool abandoned = false;
  };
  using EntryPtr = std::shared_ptr<Entry>;
  using Completion = std::pair<ReplyHandler, Result<Reply>>;

  Link* link = nullptr;
  ChannelOptions options;
  mutable std::mutex mutex;
  std::deque<EntryPtr> pending;  // sent, in order
  std::deque<EntryPtr> queued;   // waiting for the window
  std::size_t outstanding = 0;   // bytes of pending lines
  UnsolicitedHandler unsolicited;
  Link::StateHandler state_handler;
  std::uint64_t decode_errors = 0;
  std::string last_decode_error;
  SequenceTracker tracker;
  StreamDecoder<In> decoder;  // io thread only
  // Sweeps deadlines of posted requests while any wait (io thread only after creation).
  std::shared_ptr<boost::asio::steady_timer> timer;
  bool timer_armed = false;  // under the mutex
  static constexpr std::chrono::milliseconds kSweepTick{10};
  // Liveness (ChannelOptions::heartbeat), under the mutex: when the connection in place came
  // up or last delivered a byte, when a request last went out.
  std::shared_ptr<boost::asio::steady_timer> heartbeat_timer;
  bool link_up = false;
  std::int64_t last_rx_us = 0;
  std::int64_t last_tx_us = 0;
  std::uint64_t heartbeat_drops = 0;
  std::string drop_reason;
  std::int64_t last_tick_us = 0;  // io thread only
  static constexpr std::chrono::milliseconds kHeartbeatTick{50};
  // A tick this much later than due: this process (or its io thread) was not running, and what
  // the peer sent meanwhile may wait unread behind the tick; such a tick judges nothing.
  static constexpr std::int64_t kLateTickUs = 100000;

  // io thread: every tick, pings a quiet peer and ends the connection of a hung one. The
  // timer is passed along (the destructor takes the member away and cancels it).
  static void arm_heartbeat(std::weak_ptr<State> weak,
                            std::shared_ptr<boost::asio::steady_timer> t) {
    t->expires_after(kHeartbeatTick);
    t->async_wait([weak, t](const boost::system::error_code& ec) {
      if (ec) return;
      auto st = weak.lock();
      if (!st) return;
      st->heartbeat_tick();
      arm_heartbeat(weak, t);
    });
  }

  void heartbeat_tick() {
    const std::int64_t now = steady_now_us();
    const bool late =
        last_tick_us != 0 && now - last_tick_us > kHeartbeatTick.count() * 1000 + kLateTickUs;
    last_tick_us = now;
    if (late) return;
    std::vector<Completion> done;
    bool drop = false;
    {
      std::lock_guard lock(mutex);
      if (!link_up) return;
      if (!pending.empty()) {
        const EntryPtr& oldest = pending.front();
        const std::int64_t waited = now - oldest->reply.sent_steady_us;
        const std::int64_t quiet = now - last_rx_us;
        if (waited > oldest->allowance_us && quiet > options.dead_after.count() * 1000) {
          drop_reason = "no reply to " + oldest->code + " for " + std::to_string(waited / 1000) +
                        " ms and nothing else received (the peer hangs)";
          ++heartbeat_drops;
          link_up = false;
          drop = true;
        }
      } else if (queued.empty() && now - last_tx_us >= options.heartbeat.count() * 1000) {
        auto e = make_entry(Out{Ping{}}, nullptr, options.dead_after);
        if (e) (void)submit(*e);
      }
    }
    // the link reports the loss through on_state, which fails what is pending
    if (drop) link->drop();
  }

  // Under the lock: makes sure the sweep timer runs while requests wait for replies.
  void arm_sweep(const std::shared_ptr<State>& self) {
    if (timer_armed || !timer) return;
    timer_armed = true;
    boost::asio::post(timer->get_executor(), [weak = std::weak_ptr<State>(self), t = timer] {
      t->expires_after(kSweepTick);
      t->async_wait([weak, t](const boost::system::error_code& ec) {
        if (ec) return;
        auto st = weak.lock();
        if (!st) return;
        std::vector<Completion> done;
        {
          std::lock_guard lock(st->mutex);
          st->timer_armed = false;
          st->sweep(steady_now_us(), done);
          bool waiting = false;
          for (auto* q : {&st->pending, &st->queued}) {
            for (auto& e : *q) waiting = waiting || (!e->abandoned && e->handler);
          }
          if (waiting) st->arm_sweep(st);
        }
        run(done);
      });
    });
  }

  bool fits(std::size_t size) const {
    return options.window_bytes == 0 || outstanding == 0 ||
           outstanding + size <= options.window_bytes;
  }

  // Under the lock: sends queued entries while the window allows.
  void flush(std::vector<Completion>& done) {
    while (!queued.empty() && fits(queued.front()->bytes.size())) {
      EntryPtr e = queued.front();
      queued.pop_front();
      if (e->abandoned) continue;
      transmit(e, done);
    }
  }

  void transmit(const EntryPtr& e, std::vector<Completion>& done) {
    e->reply.sent_steady_us = steady_now_us();
    last_tx_us = e->reply.sent_steady_us;
    if (Status s = link->send(e->bytes); !s) {
      if (e->handler) done.emplace_back(std::move(e->handler), s.error());
      return;
    }
    outstanding += e->bytes.size();
    pending.push_back(e);
  }

  // Under the lock: sends `e` now or queues it behind the window.
  Status submit(const EntryPtr& e) {
    if (queued.empty() && fits(e->bytes.size())) {
      e->reply.sent_steady_us = steady_now_us();
      last_tx_us = e->reply.sent_steady_us;
      Status status = link->send(e->bytes);
      if (status) {
        outstanding += e->bytes.size();
        pending.push_back(e);
      }
      return status;
    }
    if (!link->connected()) {
      return Error{static_cast<int>(TransportError::kNotConnected),
                   link->name() + " is not connected"};
    }
    queued.push_back(e);
    return Ok{};
  }

  Result<EntryPtr> make_entry(const Out& message, ReplyHandler handler, Duration timeout) {
    Result<std::string> bytes = protocol::encode(message);
    if (!bytes) return bytes.error();
    auto e = std::make_shared<Entry>();
    e->bytes = std::move(bytes.value());
    e->code = e->bytes.substr(0, 2);
    e->seq = seq_of(message);
    e->handler = std::move(handler);
    e->deadline_us = steady_now_us() + timeout.count() * 1000;
    const bool slow = std::find(options.slow_codes.begin(), options.slow_codes.end(), e->code) !=
                      options.slow_codes.end();
    e->allowance_us =
        (slow ? std::max(timeout, options.dead_after) : options.dead_after).count() * 1000;
    return e;
  }

  void pop_front_pending() {
    outstanding -= std::min(outstanding, pending.front()->bytes.size());
    pending.pop_front();
  }

  // Under the lock: requests past their deadline get a timeout and stay in line.
  void sweep(std::int64_t now_us, std::vector<Completion>& done) {
    auto expire = [&](const EntryPtr& e) {
      if (!e->abandoned && e->deadline_us > 0 && now_us > e->deadline_us) {
        e->abandoned = true;
        if (e->handler) {
          done.emplace_back(std::move(e->handler),
                            proto_error(core::kErrTimeout,
                                        link->name() + ": no reply to " + e->code + " in time"));
        }
      }
    };
    for (auto& e : pending) expire(e);
    for (auto& e : queued) expire(e);
  }

  void fail_all(std::int32_t code, const std::string& why, std::vector<Completion>& done) {
    for (auto* q : {&pending, &queued}) {
      for (auto& e : *q) {
        if (!e->abandoned && e->handler) {
          done.emplace_back(std::move(e->handler),
                            proto_error(code, link->name() + ": " + e->code + " " + why));
        }
      }
      q->clear();
    }
    outstanding = 0;
  }

  static void run(std::vector<Completion>& done) {
    for (auto& [handler, result] : done) {
      if (handler) handler(std::move(result));
    }
  }

  void on_message(In&& msg, const RxPacket& packet) {
    std::vector<Completion> done;
    bool routed = false;
    {
      std::lock_guard lock(mutex);
      if (auto seq = state_seq(msg)) link->add_lost_packets(tracker.observe(*seq));
      sweep(packet.steady_us, done);
      std::size_t i = 0;
      ReplyMatch match = ReplyMatch::kNo;
      for (; i < pending.size(); ++i) {
        match = reply_match(pending[i]->code, pending[i]->seq, msg);
        if (match != ReplyMatch::kNo || !pending[i]->abandoned) break;
      }
      if (i < pending.size() && match != ReplyMatch::kNo) {
        routed = true;
        for (std::size_t k = 0; k < i; ++k) pop_front_pending();  // timed out before it
        EntryPtr e = pending.front();
        e->reply.rx_steady_us = packet.steady_us;
        e->reply.rx_system_us = packet.system_us;
        if (match == ReplyMatch::kPartial) {
          e->reply.messages.push_back(std::move(msg));
        } else {
          pop_front_pending();
          if (!e->abandoned && e->handler) {
            if (const auto* er = std::get_if<ErrorReply>(&msg)) {
              std::string text = link->name() + ": " + e->code + " refused: " +
                                 core::error_name(static_cast<std::uint8_t>(er->code)) + " (" +
                                 std::to_string(er->code) + ")";
              if (er->detail) text += ", detail " + std::to_string(*er->detail);
              Error refused = proto_error(er->code, text);
              if (er->detail) refused.detail = static_cast<int>(*er->detail);
              done.emplace_back(std::move(e->handler), std::move(refused));
            } else {
              e->reply.messages.push_back(std::move(msg));
              done.emplace_back(std::move(e->handler), std::move(e->reply));
            }
          }
          flush(done);
        }
      }
    }
    run(done);
    // A state report is an observation of the peer whatever asked for it: one that answers
    // a request (QS) goes to the subscriber too, so a monitor sees every report the peer sent.
    if (!routed || state_seq(msg).has_value()) {
      UnsolicitedHandler handler;
      {
        std::lock_guard lock(mutex);
        handler = unsolicited;
      }
      if (handler) handler(std::move(msg), packet);
    }
  }

  void on_packet(RxPacket&& packet) {
    {
      std::lock_guard lock(mutex);
      last_rx_us = std::max(last_rx_us, packet.steady_us);
    }
    std::string bytes;
    if (packet.kind == FrameKind::kOverlong || packet.kind == FrameKind::kOversize) {
      count_decode_error(packet.kind == FrameKind::kOverlong
                             ? "line longer than the link's limit"
                             : "image payload above the limit, skipped");
      return;
    }
    bytes.reserve(packet.line.size() + 1 + packet.payload.size());
    bytes.append(packet.line);
    bytes.push_back('\n');
    bytes.append(reinterpret_cast<const char*>(packet.payload.data()), packet.payload.size());
    decoder.feed(bytes, [&](Decoded<In>&& d) {
      if (auto* err = std::get_if<DecodeError>(&d)) {
        count_decode_error(err->message);
        return;
      }
      on_message(std::get<In>(std::move(d)), packet);
    });
  }

  void count_decode_error(std::string message) {
    link->add_error();
    std::lock_guard lock(mutex);
    ++decode_errors;
    last_decode_error = std::move(message);
  }

  void on_state(LinkState s) {
    std::vector<Completion> done;
    Link::StateHandler forward;
    {
      std::lock_guard lock(mutex);
      if (s != LinkState::kConnected) {
        fail_all(core::kErrDisconnected,
                 std::string("failed: link ") + link_state_name(s) +
                     (drop_reason.empty() ? std::string() : ": " + drop_reason),
                 done);
        link_up = false;
      } else {
        link_up = true;
        last_rx_us = steady_now_us();
        drop_reason.clear();
      }
      decoder.reset();
      tracker.reset();
      forward = state_handler;
    }
    run(done);
    if (forward) forward(s);
  }
};

template <class Out, class In>
Channel<Out, In>::Channel(Link& link, ChannelOptions options)
    : link_(link), state_(std::make_shared<State>()) {
  state_->link = &link;
  state_->options = options;
  state_->timer = std::make_shared<boost::asio::steady_timer>(link.io_thread().context());
  state_->link_up = link.connected();
  state_->last_rx_us = steady_now_us();
  link_.set_packet_handler([st = state_](RxPacket&& p) { st->on_packet(std::move(p)); });
  link_.set_state_handler([st = state_](LinkState s) { st->on_state(s); });
  if (options.heartbeat.count() > 0) {
    state_->heartbeat_timer =
        std::make_shared<boost::asio::steady_timer>(link.io_thread().context());
    boost::asio::post(link.io_thread().context(),
                      [weak = std::weak_ptr<State>(state_), t = state_->heartbeat_timer] {
                        State::arm_heartbeat(weak, t);
                      });
  }
}

template <class Out, class In>
Channel<Out, In>::~Channel() {
  link_.set_packet_handler(nullptr);
  link_.set_state_handler(nullptr);
  std::vector<typename State::Completion> done;
  {
    std::lock_guard lock(state_->mutex);
    state_->fail_all(core::kErrDisconnected, "failed: channel closed", done);
    // the timer is cancelled and destroyed on the io thread, where its handler runs
    auto timer = std::move(state_->timer);
    boost::asio::post(timer->get_executor(), [timer] { timer->cancel(); });
    if (auto hb = std::move(state_->heartbeat_timer)) {
      boost::asio::post(hb->get_executor(), [hb] { hb->cancel(); });
    }
  }
  State::run(done);
  // A packet being delivered right now may still be on its way to the handlers (they are
  // called outside the lock): once they are cleared and the io thread has passed a barrier,
  // none of the owner's handlers runs after this destructor returns (the owner may be going
  // away with us).
  {
    std::lock_guard lock(state_->mutex);
    state_->unsolicited = nullptr;
    state_->state_handler = nullptr;
  }
  IoThread& io = link_.io_thread();
  if (!io.in_io_thread()) {
    auto passed = std::make_shared<std::promise<void>>();
    auto future = passed->get_future();
    boost::asio::post(io.context(), [passed] { passed->set_value(); });
    // bounded: an io thread that no longer runs has no handler in flight either
    (void)future.wait_for(std::chrono::seconds(2));
  }
}

template <class Out, class In>
Status Channel<Out, In>::post(const Out& message, ReplyHandler on_reply, Duration timeout) {
  auto e = state_->make_entry(message, std::move(on_reply), timeout);
  if (!e) return e.error();
  std::vector<typename State::Completion> done;
  Status status = Ok{};
  {
    std::lock_guard lock(state_->mutex);
    state_->sweep(steady_now_us(), done);
    status = state_->submit(*e);
    if (status && (*e)->handler) state_->arm_sweep(state_);
  }
  State::run(done);
  return status;
}

template <class Out, class In>
auto Channel<Out, In>::request(const Out& message, Duration timeout) -> Result<Reply> {
  struct Waiter {
    std::mutex m;
    std::condition_variable cv;
    std::optional<Result<Reply>> result;
  };
  auto w = std::make_shared<Waiter>();
  auto e = state_->make_entry(
      message,
      [w](Result<Reply>&& r) {
        std::lock_guard lock(w->m);
        w->result.emplace(std::move(r));
        w->cv.notify_all();
      },
      timeout);
  if (!e) return e.error();
  std::vector<typename State::Completion> done;
  Status status = Ok{};
  {
    std::lock_guard lock(state_->mutex);
    state_->sweep(steady_now_us(), done);
    status = state_->submit(*e);
  }
  State::run(done);
  if (!status) return status.error();
  std::unique_lock lock(w->m);
  if (w->cv.wait_for(lock, timeout, [&] { return w->result.has_value(); })) {
    return std::move(*w->result);
  }
  lock.unlock();
  {
    // give up: the request stays in line (abandoned) so that its late reply is skipped
    std::lock_guard slock(state_->mutex);
    (*e)->abandoned = true;
    (*e)->handler = nullptr;
  }
  lock.lock();
  if (w->result) return std::move(*w->result);  // it arrived meanwhile
  return proto_error(core::kErrTimeout, link_.name() + ": no reply to " + (*e)->code + " within " +
                                            std::to_string(timeout.count()) + " ms");
}

template <class Out, class In>
Status Channel<Out, In>::send_realtime(protocol::Realtime command) {
  return link_.send(std::string(1, static_cast<char>(command)));
}

template <class Out, class In>
void Channel<Out, In>::forget_abandoned() {
  std::vector<typename State::Completion> done;
  {
    std::lock_guard lock(state_->mutex);
    auto& pending = state_->pending;
    for (auto it = pending.begin(); it != pending.end();) {
      if ((*it)->abandoned) {
        state_->outstanding -= std::min(state_->outstanding, (*it)->bytes.size());
        it = pending.erase(it);
      } else {
        ++it;
      }
    }
    state_->flush(done);  // the window they held is free
  }
  State::run(done);
}

template <class Out, class In>
void Channel<Out, In>::fail_pending(const std::string& why) {
  std::vector<typename State::Completion> done;
  {
    std::lock_guard lock(state_->mutex);
    const auto fail = [&](const typename State::EntryPtr& e) {
      if (e->abandoned) return;
      e->abandoned = true;
      if (e->handler) {
        done.emplace_back(
            std::move(e->handler),
            proto_error(core::kErrDisconnected, link_.name() + ": " + e->code + " failed: " + why));
      }
    };
    for (auto& e : state_->pending) fail(e);
    for (auto& e : state_->queued) fail(e);
    state_->queued.clear();
  }
  State::run(done);
}

template <class Out, class In>
void Channel<Out, In>::set_unsolicited_handler(UnsolicitedHandler handler) {
  std::lock_guard lock(state_->mutex);
  state_->unsolicited = std::move(handler);
}

template <class Out, class In>
void Channel<Out, In>::set_state_handler(Link::StateHandler handler) {
  std::lock_guard lock(state_->mutex);
  state_->state_handler = std::move(handler);
}

template <class Out, class In>
std::size_t Channel<Out, In>::in_flight() const {
  std::lock_guard lock(state_->mutex);
  return state_->pending.size();
}

template <class Out, class In>
std::size_t Channel<Out, In>::queued() const {
  std::lock_guard lock(state_->mutex);
  return state_->queued.size();
}

template <class Out, class In>
std::uint64_t Channel<Out, In>::decode_errors() const {
  std::lock_guard lock(state_->mutex);
  return state_->decode_errors;
}

template <class Out, class In>
std::string Channel<Out, In>::last_decode_error() const {
  std::lock_guard lock(state_->mutex);
  return state_->last_decode_error;
}

template <class Out, class In>
std::uint64_t Channel<Out, In>::lost_packets() const {
  std::lock_guard lock(state_->mutex);
  return state_->tracker.lost();
}

template <class Out, class In>
std::uint64_t Channel<Out, In>::heartbeat_drops() const {
  std::lock_guard lock(state_->mutex);
  return state_->heartbeat_drops;
}

template <class Out, class In>
std::string Channel<Out, In>::last_drop_reason() const {
  std::lock_guard lock(state_->mutex);
  return state_->drop_reason;
}

template class Channel<protocol::SerialToDevice, protocol::SerialFromDevice>;
template class Channel<protocol::TcpToSim, protocol::TcpFromSim>;

}  // namespace scaratwin::transport
