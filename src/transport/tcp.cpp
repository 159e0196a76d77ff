#include <utility>  // before Boost.Asio (Boost 1.74 misses it)

#include "scaratwin/transport/tcp.hpp"

#include <boost/asio/connect.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/post.hpp>
#include <boost/asio/steady_timer.hpp>

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
      : LinkImpl(std::move(io), options.link, std::move(name)), acceptor_(context()) {}

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
      self->attach(std::move(s));
      self->accept();
    });
  }

  void attach(tcp::socket socket) {
    if (session_) {  // a new peer replaces the current one
      session_->stop();
      session_.reset();
      on_disconnected(false);
    }
    tune_socket(socket);
    const std::uint32_t connection = on_connected();
    session_ = std::make_shared<Session>(shared_from_this(), std::move(socket), connection,
                                         [self = self()](bool error) {
                                           self->session_.reset();
                                           self->on_disconnected(error);
                                         });
    session_->start();
  }

  tcp::acceptor acceptor_;
  std::shared_ptr<Session> session_;
  std::uint16_t port_ = 0;
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
