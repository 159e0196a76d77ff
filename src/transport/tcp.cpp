#include <utility>  // before Boost.Asio (Boost 1.74 misses it)

#include "scaratwin/transport/tcp.hpp"

#include <algorithm>
#include <array>
#include <vector>

#include <boost/asio/connect.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/post.hpp>
#include <boost/asio/steady_timer.hpp>
#include <boost/asio/write.hpp>

#include "link_impl.hpp"
#include "stream_session.hpp"

namespace scaratwin::transport {

namespace asio = boost::asio;
using asio::ip::tcp;

LinkOptions tcp_link_defaults() {
  LinkOptions o;
  o.splitter.max_line_bytes = 511;  // 512 with the newline
  o.splitter.binary_prefix = "IM,";
  o.splitter.binary_delimiter = ',';
  return o;
}

namespace {

using Session = detail::StreamSession<tcp::socket>;
using detail::bad_option;
using detail::check_link_options;

// The same connection as a socket newly registered with the reactor, for a reader that takes
// over from another. Asio's epoll reactor tries no read at once after one that drained the
// socket, and waits for the next edge: an end of stream, or bytes that arrived with the ones
// the first reader took, would never be seen by the second.
tcp::socket rewrap(tcp::socket&& s, asio::io_context& io) {
  boost::system::error_code ec;
  const tcp::endpoint local = s.local_endpoint(ec);
  const tcp protocol = ec ? tcp::v4() : local.protocol();
  const tcp::socket::native_handle_type fd = s.release(ec);
  tcp::socket fresh(io);
  if (!ec) fresh.assign(protocol, fd, ec);
  return fresh;
}

void tune_socket(tcp::socket& s) {
  boost::system::error_code ignored;
  s.set_option(tcp::no_delay(true), ignored);
  s.set_option(asio::socket_base::keep_alive(true), ignored);
}

// --- client ----------------------------------------------------------------------------------

class TcpClientImpl final : public detail::LinkImpl {
 public:
  TcpClientImpl(std::shared_ptr<IoThread> io, TcpClientOptions options)
      : LinkImpl(std::move(io), options.link,
                 "tcp-client " + options.host + ":" + std::to_string(options.port)),
        options_(std::move(options)),
        resolver_(context()),
        timer_(context()) {}

 protected:
  void start() override { attempt(); }

  void write(std::shared_ptr<std::string> bytes, std::uint64_t packets) override {
    session_->write(std::move(bytes), packets);
  }

  bool can_write() const override { return session_ && !session_->stopped(); }

  void drop_connection() override {
    if (!session_) return;
    session_->stop();
    lost(true);
  }

  void shutdown() override {
    resolver_.cancel();
    timer_.cancel();
    if (socket_) {
      boost::system::error_code ignored;
      socket_->close(ignored);
      socket_.reset();
    }
    if (session_) session_->stop();
    session_.reset();
  }

 private:
  std::shared_ptr<TcpClientImpl> self() {
    return std::static_pointer_cast<TcpClientImpl>(shared_from_this());
  }

  void attempt() {
    if (closed()) return;
    set_state(LinkState::kConnecting);
    const std::uint64_t gen = ++attempt_gen_;
    timer_.expires_after(options_.connect_timeout);
    timer_.async_wait([self = self(), gen](const boost::system::error_code& ec) {
      if (ec || self->closed() || gen != self->attempt_gen_) return;
      // the attempt took too long: abandon it
      self->resolver_.cancel();
      if (self->socket_) {
        boost::system::error_code ignored;
        self->socket_->close(ignored);
      }
    });
    resolver_.async_resolve(
        options_.host, std::to_string(options_.port),
        [self = self(), gen](const boost::system::error_code& ec,
                             tcp::resolver::results_type results) {
          if (self->closed() || gen != self->attempt_gen_) return;
          if (ec) {
            self->retry();
            return;
          }
          // the pending operation keeps its socket alive: shutdown() only closes it
          auto sock = std::make_shared<tcp::socket>(self->context());
          self->socket_ = sock;
          asio::async_connect(
              *sock, results,
              [self, gen, sock](const boost::system::error_code& cec, const tcp::endpoint&) {
                if (self->closed() || gen != self->attempt_gen_) return;
                if (cec || !self->socket_ || !self->socket_->is_open()) {
                  self->retry();
                  return;
                }
                self->connected();
              });
        });
  }

  void connected() {
    ++attempt_gen_;  // disarm the attempt timer
    timer_.cancel();
    tune_socket(*socket_);
    tcp::socket socket = std::move(*socket_);
    socket_.reset();
    const std::uint32_t connection = on_connected();
    session_ = std::make_shared<Session>(shared_from_this(), std::move(socket), connection,
                                         [self = self()](bool error) { self->lost(error); });
    session_->start();
  }

  void lost(bool error) {
    session_.reset();
    on_disconnected(error);
    if (!closed() && options().auto_reconnect) schedule_retry();
  }

  void retry() {
    ++attempt_gen_;
    if (socket_) {
      boost::system::error_code ignored;
      socket_->close(ignored);
      socket_.reset();
    }
    if (!options().auto_reconnect) {
      set_state(LinkState::kDisconnected);
      return;
    }
    schedule_retry();
  }

  void schedule_retry() {
    if (closed()) return;
    set_state(LinkState::kConnecting);
    const std::uint64_t gen = ++attempt_gen_;
    timer_.expires_after(next_retry_delay());
    timer_.async_wait([self = self(), gen](const boost::system::error_code& ec) {
      if (ec || self->closed() || gen != self->attempt_gen_) return;
      self->attempt();
    });
  }

  TcpClientOptions options_;
  tcp::resolver resolver_;
  asio::steady_timer timer_;
  std::shared_ptr<tcp::socket> socket_;  // during a connection attempt
  std::shared_ptr<Session> session_;
  std::uint64_t attempt_gen_ = 0;
};

// --- server ----------------------------------------------------------------------------------

class TcpServerImpl final : public detail::LinkImpl {
 public:
  TcpServerImpl(std::shared_ptr<IoThread> io, const TcpServerOptions& options, std::string name)
      : LinkImpl(std::move(io), options.link, std::move(name)),
        acceptor_(context()),
        admit_(options.admit),
        observe_(options.observe),
        first_line_timeout_(options.first_line_timeout),
        max_observers_(options.max_observers) {}

  Status listen(const TcpServerOptions& options) {
    boost::system::error_code ec;
    auto address = asio::ip::make_address(options.bind_address, ec);
    if (ec) {
      return bad_option("tcp-server: bind address '" + options.bind_address +
                        "' is not an IP address (e.g. 127.0.0.1 or 0.0.0.0)");
    }
    tcp::endpoint endpoint(address, options.port);
    acceptor_.open(endpoint.protocol(), ec);
    if (!ec) acceptor_.set_option(tcp::acceptor::reuse_address(true), ec);
    if (!ec) acceptor_.bind(endpoint, ec);
    if (!ec) acceptor_.listen(asio::socket_base::max_listen_connections, ec);
    if (ec) {
      return Error{static_cast<int>(TransportError::kOpenFailed),
                   "tcp-server: cannot listen on " + options.bind_address + ":" +
                       std::to_string(options.port) + ": " + ec.message()};
    }
    port_ = acceptor_.local_endpoint().port();
    rename("tcp-server " + options.bind_address + ":" + std::to_string(port_));
    set_state(LinkState::kDisconnected);
    return Ok{};
  }

  std::uint16_t port() const { return port_; }

 protected:
  void start() override { accept(); }

  void write(std::shared_ptr<std::string> bytes, std::uint64_t packets) override {
    session_->write(std::move(bytes), packets);
  }

  bool can_write() const override { return session_ && !session_->stopped(); }

  void shutdown() override {
    boost::system::error_code ignored;
    acceptor_.close(ignored);
    if (session_) session_->stop();
    session_.reset();
    for (auto& w : observers_) {
      if (auto o = w.lock()) o->socket.close(ignored);
    }
    observers_.clear();
    for (auto& w : served_) {
      if (auto o = w.lock()) o->socket.close(ignored);
    }
    served_.clear();
  }

 private:
  std::shared_ptr<TcpServerImpl> self() {
    return std::static_pointer_cast<TcpServerImpl>(shared_from_this());
  }

  void accept() {
    acceptor_.async_accept([self = self()](const boost::system::error_code& ec, tcp::socket s) {
      if (self->closed()) return;
      if (ec) {
        self->count_error();
        // e.g. out of descriptors: try again shortly instead of spinning
        auto timer = std::make_shared<asio::steady_timer>(self->context());
        timer->expires_after(self->next_retry_delay());
        timer->async_wait([self, timer](const boost::system::error_code&) {
          if (!self->closed()) self->accept();
        });
        return;
      }
      if (self->admit_) {
        self->judge(std::move(s));
      } else {
        self->attach(std::move(s), {});
      }
      self->accept();
    });
  }

  // A connection waiting for its first line, then judged by admit_.
  struct Newcomer {
    Newcomer(tcp::socket s, asio::io_context& io) : socket(std::move(s)), timer(io) {}
    tcp::socket socket;
    asio::steady_timer timer;
    std::string bytes;  // everything received so far
    std::string peer;
    std::array<char, 4096> buffer{};
    bool judged = false;
  };

  void judge(tcp::socket socket) {
    auto n = std::make_shared<Newcomer>(std::move(socket), context());
    boost::system::error_code ec;
    const auto remote = n->socket.remote_endpoint(ec);
    n->peer =
        ec ? std::string("?") : remote.address().to_string() + ":" + std::to_string(remote.port());
    n->timer.expires_after(first_line_timeout_);
    n->timer.async_wait([self = self(), n](const boost::system::error_code& tec) {
      if (tec || self->closed() || n->judged) return;
      self->decide(n, false);
    });
    read_first_line(n);
  }

  void read_first_line(const std::shared_ptr<Newcomer>& n) {
    n->socket.async_read_some(
        asio::buffer(n->buffer),
        [self = self(), n](const boost::system::error_code& ec, std::size_t got) {
          if (self->closed() || n->judged) return;
          n->bytes.append(n->buffer.data(), got);
          const std::size_t limit = self->options().splitter.max_line_bytes;
          if (n->bytes.find('\n') != std::string::npos || n->bytes.size() > limit) {
            self->decide(n, true);
          } else if (ec) {
            // ended before its first line: it holds nothing and nothing of it runs
            n->judged = true;
            n->timer.cancel();
            boost::system::error_code ignored;
            n->socket.close(ignored);
          } else {
            self->read_first_line(n);
          }
        });
  }

  void decide(const std::shared_ptr<Newcomer>& n, bool complete) {
    n->judged = true;
    n->timer.cancel();
    std::string_view first(n->bytes);
    const std::size_t limit = options().splitter.max_line_bytes;
    first = first.substr(0, std::min(first.find('\n'), limit));
    if (!first.empty() && first.back() == '\r') first.remove_suffix(1);
    AdmissionDecision d = admit_(first, complete, n->peer, session_ != nullptr);
    if (d.admission == Admission::kControl && session_) d.admission = Admission::kRefuse;
    switch (d.admission) {
      case Admission::kControl:
        attach(rewrap(std::move(n->socket), context()), std::move(n->bytes));
        return;
      case Admission::kObserve:
        observe(n);
        return;
      case Admission::kServe:
        serve_apart(n, std::move(d));
        return;
      case Admission::kRefuse:
        refuse(std::move(n->socket), std::move(d.reply));
        return;
    }
  }

  void refuse(tcp::socket socket, std::string reply) {
    auto s = std::make_shared<tcp::socket>(std::move(socket));
    auto bytes = std::make_shared<std::string>(std::move(reply));
    asio::async_write(*s, asio::buffer(*bytes),
                      [s, bytes](const boost::system::error_code&, std::size_t) {
                        boost::system::error_code ignored;
                        s->shutdown(tcp::socket::shutdown_both, ignored);
                        s->close(ignored);
                      });
  }

  // A connection served apart (an observer, or kServe): its own splitter, its frames answered
  // by `serve` in order, one at a time; `closed` runs once when it ends.
  struct Observer {
    Observer(tcp::socket s, const SplitterOptions& o, ServeFn fn, std::function<void()> on_close)
        : socket(std::move(s)), splitter(o), serve(std::move(fn)), closed(std::move(on_close)) {}
    // Closes the connection; `closed` runs once (not when the server itself closes).
    void end() {
      boost::system::error_code ignored;
      socket.close(ignored);
      if (closed) std::exchange(closed, nullptr)();
    }
    tcp::socket socket;
    LineSplitter splitter;
    ServeFn serve;
    std::function<void()> closed;
    std::array<char, 4096> buffer{};
  };

  void observe(const std::shared_ptr<Newcomer>& n) {
    std::erase_if(observers_, [](const std::weak_ptr<Observer>& w) { return w.expired(); });
    if (!observe_ || observers_.size() >= max_observers_) {
      boost::system::error_code ignored;
      n->socket.close(ignored);
      return;
    }
    tcp::socket socket = rewrap(std::move(n->socket), context());
    tune_socket(socket);
    auto o = std::make_shared<Observer>(std::move(socket), options().splitter, observe_,
                                        std::function<void()>{});
    observers_.push_back(o);
    serve_observer(o, std::move(n->bytes));
  }

  void serve_apart(const std::shared_ptr<Newcomer>& n, AdmissionDecision d) {
    std::erase_if(served_, [](const std::weak_ptr<Observer>& w) { return w.expired(); });
    tcp::socket socket = rewrap(std::move(n->socket), context());
    tune_socket(socket);
    auto o = std::make_shared<Observer>(std::move(socket), options().splitter, std::move(d.serve),
                                        std::move(d.closed));
    served_.push_back(o);
    serve_observer(o, std::move(n->bytes));
  }

  void serve_observer(const std::shared_ptr<Observer>& o, std::string_view bytes) {
    auto reply = std::make_shared<std::string>();
    o->splitter.feed(bytes, [&](Frame&& f) { reply->append(o->serve(f)); });
    auto next = [self = self(), o](const boost::system::error_code& ec, std::size_t) {
      if (self->closed()) return;
      if (ec) {
        o->end();
        return;
      }
      o->socket.async_read_some(asio::buffer(o->buffer),
                                [self, o](const boost::system::error_code& rec, std::size_t got) {
                                  if (self->closed()) return;
                                  if (got > 0)
                                    self->serve_observer(o,
                                                         std::string_view(o->buffer.data(), got));
                                  if (rec) o->end();
                                });
    };
    if (reply->empty()) {
      next({}, 0);
    } else {
      asio::async_write(
          o->socket, asio::buffer(*reply),
          [reply, next](const boost::system::error_code& ec, std::size_t n) { next(ec, n); });
    }
  }

  // `first_bytes`: what the admission read of the connection, delivered before the rest.
  void attach(tcp::socket socket, std::string first_bytes) {
    if (session_) {  // a new peer replaces the current one
      session_->stop();
      session_.reset();
      on_disconnected(false);
    }
    tune_socket(socket);
    const std::uint32_t connection = on_connected();
    auto session = std::make_shared<Session>(shared_from_this(), std::move(socket), connection,
                                             [self = self()](bool error) {
                                               self->session_.reset();
                                               self->on_disconnected(error);
                                             });
    session_ = session;
    if (!first_bytes.empty()) {
      on_bytes(first_bytes, connection);
      if (closed() || session_ != session) return;  // a handler closed the link
    }
    session->start();
  }

  tcp::acceptor acceptor_;
  std::shared_ptr<Session> session_;
  std::uint16_t port_ = 0;
  AdmitFn admit_;
  ObserveFn observe_;
  Duration first_line_timeout_{10000};
  std::size_t max_observers_ = 8;
  std::vector<std::weak_ptr<Observer>> observers_;
  std::vector<std::weak_ptr<Observer>> served_;
};

}  // namespace

Result<std::unique_ptr<TcpClient>> TcpClient::create(TcpClientOptions options,
                                                     std::shared_ptr<IoThread> io) {
  if (options.host.empty()) return bad_option("tcp-client: host is empty, e.g. 127.0.0.1");
  if (options.port == 0) return bad_option("tcp-client: port 0, need 1..65535");
  if (options.connect_timeout.count() <= 0) {
    return bad_option("tcp-client: connect_timeout " +
                      std::to_string(options.connect_timeout.count()) + " ms, need > 0");
  }
  if (auto s = check_link_options(options.link, "tcp-client"); !s) return s.error();
  auto impl = std::make_shared<TcpClientImpl>(std::move(io), std::move(options));
  impl->launch();
  return std::unique_ptr<TcpClient>(new TcpClient(impl));
}

Result<std::unique_ptr<TcpServer>> TcpServer::create(TcpServerOptions options,
                                                     std::shared_ptr<IoThread> io) {
  if (auto s = check_link_options(options.link, "tcp-server"); !s) return s.error();
  auto impl = std::make_shared<TcpServerImpl>(
      std::move(io), options,
      "tcp-server " + options.bind_address + ":" + std::to_string(options.port));
  if (auto s = impl->listen(options); !s) return s.error();
  impl->launch();
  const std::uint16_t port = impl->port();
  return std::unique_ptr<TcpServer>(new TcpServer(impl, port));
}

}  // namespace scaratwin::transport
