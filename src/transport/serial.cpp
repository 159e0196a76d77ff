#include <utility>  // before Boost.Asio (Boost 1.74 misses it)

#include "scaratwin/transport/serial.hpp"

#include <sys/ioctl.h>
#include <termios.h>

#include <algorithm>
#include <array>
#include <boost/asio/serial_port.hpp>
#include <boost/asio/steady_timer.hpp>

#include "link_impl.hpp"
#include "stream_session.hpp"

namespace scaratwin::transport {

namespace asio = boost::asio;

LinkOptions serial_link_defaults() {
  LinkOptions o;
  o.splitter.max_line_bytes = 95;  // 96 with the newline
  o.splitter.binary_prefix.clear();
  return o;
}

namespace {

constexpr std::array<unsigned, 12> kBauds{9600,   19200,  38400,  57600,  115200,  230400,
                                          460800, 500000, 576000, 921600, 1000000, 2000000};

using Session = detail::StreamSession<asio::serial_port>;

// Raw 8N1 without flow control, reads return as soon as one byte is there.
boost::system::error_code configure(asio::serial_port& port, const SerialOptions& options) {
  boost::system::error_code ec;
  using sp = asio::serial_port_base;
  port.set_option(sp::baud_rate(options.baud), ec);
  if (!ec) port.set_option(sp::character_size(8), ec);
  if (!ec) port.set_option(sp::parity(sp::parity::none), ec);
  if (!ec) port.set_option(sp::stop_bits(sp::stop_bits::one), ec);
  if (!ec) port.set_option(sp::flow_control(sp::flow_control::none), ec);
  if (ec) return ec;
  const int fd = port.native_handle();
  termios tio{};
  if (::tcgetattr(fd, &tio) != 0) return {errno, boost::system::system_category()};
  const speed_t in_speed = ::cfgetispeed(&tio);
  const speed_t out_speed = ::cfgetospeed(&tio);
  ::cfmakeraw(&tio);
  ::cfsetispeed(&tio, in_speed);
  ::cfsetospeed(&tio, out_speed);
  tio.c_cflag |= CLOCAL | CREAD;
  tio.c_cflag &= ~static_cast<tcflag_t>(CRTSCTS | CSTOPB | PARENB);
  tio.c_iflag &= ~static_cast<tcflag_t>(IXON | IXOFF | IXANY);
  tio.c_cc[VMIN] = 1;
  tio.c_cc[VTIME] = 0;
  if (::tcsetattr(fd, TCSANOW, &tio) != 0) return {errno, boost::system::system_category()};
  if (options.exclusive) ::ioctl(fd, TIOCEXCL);  // best effort
  ::tcflush(fd, TCIOFLUSH);
  return {};
}

class SerialImpl final : public detail::LinkImpl {
 public:
  SerialImpl(std::shared_ptr<IoThread> io, SerialOptions options)
      : LinkImpl(std::move(io), options.link, "serial " + options.device),
        options_(std::move(options)),
        timer_(context()) {}

  // The reason of the last failed open (for diagnostics), io thread only.
  std::string last_open_error;

 protected:
  void start() override { attempt(); }

  void write(std::shared_ptr<std::string> bytes, std::uint64_t packets) override {
    session_->write(std::move(bytes), packets);
  }

  bool can_write() const override { return session_ && !session_->stopped(); }

  void shutdown() override {
    timer_.cancel();
    if (session_) session_->stop();
    session_.reset();
  }

 private:
  std::shared_ptr<SerialImpl> self() {
    return std::static_pointer_cast<SerialImpl>(shared_from_this());
  }

  void attempt() {
    if (closed()) return;
    asio::serial_port port(context());
    boost::system::error_code ec;
    port.open(options_.device, ec);
    if (!ec) ec = configure(port, options_);
    if (ec) {
      last_open_error = ec.message();
      boost::system::error_code ignored;
      port.close(ignored);
      if (!options().auto_reconnect) {
        set_state(LinkState::kDisconnected);
        return;
      }
      set_state(LinkState::kConnecting);
      schedule_retry();
      return;
    }
    const std::uint32_t connection = on_connected();
    session_ = std::make_shared<Session>(shared_from_this(), std::move(port), connection,
                                         [self = self()](bool error) { self->lost(error); });
    session_->start();
  }

  void lost(bool error) {
    session_.reset();
    on_disconnected(error);
    if (!closed() && options().auto_reconnect) schedule_retry();
  }

  void schedule_retry() {
    if (closed()) return;
    timer_.expires_after(next_retry_delay());
    timer_.async_wait([self = self()](const boost::system::error_code& ec) {
      if (ec || self->closed()) return;
      self->attempt();
    });
  }

  SerialOptions options_;
  asio::steady_timer timer_;
  std::shared_ptr<Session> session_;
};

}  // namespace

Result<std::unique_ptr<SerialLink>> SerialLink::create(SerialOptions options,
                                                       std::shared_ptr<IoThread> io) {
  if (options.device.empty()) {
    return detail::bad_option("serial: device path is empty, e.g. /dev/ttyACM0");
  }
  if (std::find(kBauds.begin(), kBauds.end(), options.baud) == kBauds.end()) {
    return detail::bad_option("serial " + options.device + ": baud " +
                              std::to_string(options.baud) +
                              " not supported; use 9600, 19200, 38400, 57600, 115200, 230400, "
                              "460800, 500000, 576000, 921600, 1000000 or 2000000");
  }
  if (auto s = detail::check_link_options(options.link, "serial " + options.device); !s) {
    return s.error();
  }
  auto impl = std::make_shared<SerialImpl>(std::move(io), std::move(options));
  impl->launch();
  return std::unique_ptr<SerialLink>(new SerialLink(impl));
}

}  // namespace scaratwin::transport
