// TCP links: the virtual link between the hub (client) and the simulator (server). Packets
// are text lines ("ID,v1,v2,...,\n"); camera images come as "IM,<nbytes>,\n" followed by the
// raw PNG bytes, which the splitter hands through intact (RxPacket::payload). Sockets use
// TCP_NODELAY and keepalive. The client reconnects on its own after a loss, with a delay
// that doubles from reconnect_min up to reconnect_max; the server keeps accepting. Without an
// admission function a new peer replaces the current one; with one (TcpServerOptions::admit)
// each new connection is judged on its first line before anything of it is delivered: it
// becomes the controlling peer, an observer (served apart, through `observe`), a connection
// served apart by a handler of its own (`serve` of the decision: e.g. a second controller that
// drives another robot of the simulator), or is refused with a reply and closed.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <string_view>

#include "scaratwin/transport/link.hpp"

namespace scaratwin::transport {

inline constexpr const char* kDefaultTcpHost = "127.0.0.1";
inline constexpr std::uint16_t kDefaultTcpPort = 55016;

// Link options for the TCP framing: lines up to 512 bytes, "IM," binary payloads.
LinkOptions tcp_link_defaults();

struct TcpClientOptions {
  std::string host = kDefaultTcpHost;  // IP address or host name
  std::uint16_t port = kDefaultTcpPort;
  Duration connect_timeout{1000};  // one connection attempt
  LinkOptions link = tcp_link_defaults();
};

class TcpClient : public Link {
 public:
  // Starts connecting at once (in the background); see wait_connected(). Fails only on
  // options that cannot work (empty host, port 0, zero timeouts).
  static Result<std::unique_ptr<TcpClient>> create(TcpClientOptions options,
                                                   std::shared_ptr<IoThread> io = nullptr);

 private:
  using Link::Link;
};

// What becomes of a new connection (TcpServerOptions::admit).
enum class Admission {
  kControl,  // the link's peer: its packets go to the link's handler or queue
  kObserve,  // served apart: each of its frames goes to TcpServerOptions::observe
  kServe,    // served apart: each of its frames goes to the decision's `serve`
  kRefuse,   // `reply` is written, then the connection is closed; nothing of it is delivered
};
// One frame of a connection served apart (its first line included) -> the bytes to answer.
// Runs on the io thread.
using ServeFn = std::function<std::string(const Frame& frame)>;
struct AdmissionDecision {
  Admission admission = Admission::kControl;
  std::string reply;  // kRefuse only
  ServeFn serve;      // kServe only: answers the connection's frames, in order, one at a time
  // kServe only: called once on the io thread when the connection has ended (closed by its
  // peer, an I/O error, or the server closing); also when it could not be served at all
  std::function<void()> closed;
};
// Judges a connection on its first line (without '\n'; cut at the line limit, or what came
// before first_line_timeout passed: then `complete` is false). A connection that ends before
// its first line is closed without a judgement.
// `peer` is "address:port"; `controller` is true while a controlling peer is attached. Runs on
// the io thread.
using AdmitFn = std::function<AdmissionDecision(std::string_view first_line, bool complete,
                                                const std::string& peer, bool controller)>;
// One frame of an observer connection (its first line included) -> the bytes to answer.
// Runs on the io thread.
using ObserveFn = ServeFn;

struct TcpServerOptions {
  std::string bind_address = kDefaultTcpHost;  // "0.0.0.0" to listen on every interface
  std::uint16_t port = kDefaultTcpPort;        // 0: an ephemeral port (see TcpServer::port())
  LinkOptions link = tcp_link_defaults();
  AdmitFn admit;                       // empty: every new peer replaces the current one
  ObserveFn observe;                   // needed for Admission::kObserve
  Duration first_line_timeout{10000};  // a connection silent this long is judged as it is
  std::size_t max_observers = 8;       // more observers are closed at once
};

class TcpServer : public Link {
 public:
  // Binds and listens before returning (kOpenFailed names the address if that fails), then
  // accepts peers in the background; connected() is true while a peer is attached.
  static Result<std::unique_ptr<TcpServer>> create(TcpServerOptions options,
                                                   std::shared_ptr<IoThread> io = nullptr);
  // The port actually listened on.
  std::uint16_t port() const { return port_; }

 private:
  TcpServer(std::shared_ptr<detail::LinkImpl> impl, std::uint16_t port)
      : Link(std::move(impl)), port_(port) {}
  std::uint16_t port_;
};

}  // namespace scaratwin::transport
