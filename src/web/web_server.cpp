// WebServer: Boost.Beast HTTP + WebSocket on one io thread (the only translation unit that
// includes Beast: it takes long to compile).
#include <utility>  // before Boost headers (Boost 1.74 with g++ 12)

// g++ 12 warns that the coroutine frames of serve() are freed by a mismatched operator
// delete: both are asio's awaitable_frame_base pair (its recycling allocator), which the
// warning does not follow through the frame once serve() has this many suspension points.
#pragma GCC diagnostic ignored "-Wmismatched-new-delete"

#include "scaratwin/web/web_server.hpp"

#include <atomic>
#include <cctype>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <deque>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>
#include <thread>
#include <vector>

#include <fmt/format.h>
#include <boost/asio.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <boost/beast/websocket.hpp>

#include "scaratwin/config/data_paths.hpp"
#include "scaratwin/web/feed.hpp"

namespace scaratwin::web {
namespace {

namespace asio = boost::asio;
namespace beast = boost::beast;
namespace http = beast::http;
namespace websocket = beast::websocket;
using tcp = asio::ip::tcp;
using asio::use_awaitable;

constexpr std::size_t kMaxRequestBytes = 64 * 1024;
constexpr std::size_t kMaxWsMessageBytes = 64 * 1024;
constexpr std::size_t kMaxQueuedFrames = 2;            // state frames queued per slow browser
constexpr std::chrono::milliseconds kAcceptRetry{50};  // after a failed accept (EMFILE, ...)

std::string_view mime_type(const std::filesystem::path& path) {
  const std::string ext = path.extension().string();
  if (ext == ".html") return "text/html; charset=utf-8";
  if (ext == ".js" || ext == ".mjs") return "text/javascript; charset=utf-8";
  if (ext == ".css") return "text/css; charset=utf-8";
  if (ext == ".json" || ext == ".map") return "application/json";
  if (ext == ".png") return "image/png";
  if (ext == ".svg") return "image/svg+xml";
  if (ext == ".ico") return "image/x-icon";
  if (ext == ".woff2") return "font/woff2";
  return "application/octet-stream";
}

// The file a request target names under root, or nothing for a path that could leave root.
std::optional<std::filesystem::path> resolve(const std::filesystem::path& root,
                                             std::string_view target) {
  const std::size_t q = target.find_first_of("?#");
  std::string_view path = target.substr(0, q);
  if (path.empty() || path[0] != '/') return std::nullopt;
  if (path.find("..") != std::string_view::npos || path.find('\\') != std::string_view::npos ||
      path.find('\0') != std::string_view::npos || path.find("//") != std::string_view::npos) {
    return std::nullopt;
  }
  std::string rel(path.substr(1));
  if (rel.empty() || rel.back() == '/') rel += "index.html";
  return root / rel;
}

// The value of `key` in the query of a request target ("/ws?token=abc" -> "abc").
std::optional<std::string_view> query_value(std::string_view target, std::string_view key) {
  const std::size_t q = target.find('?');
  if (q == std::string_view::npos) return std::nullopt;
  std::string_view query = target.substr(q + 1);
  query = query.substr(0, query.find('#'));
  while (!query.empty()) {
    const std::size_t amp = query.find('&');
    const std::string_view pair = query.substr(0, amp);
    const std::size_t eq = pair.find('=');
    if (pair.substr(0, eq) == key) {
      return eq == std::string_view::npos ? std::string_view() : pair.substr(eq + 1);
    }
    if (amp == std::string_view::npos) break;
    query.remove_prefix(amp + 1);
  }
  return std::nullopt;
}

// True when a Host header names this machine (localhost, 127.x.y.z, [::1]), with any port.
bool local_host(std::string_view host) {
  std::string_view name = host;
  if (!name.empty() && name.front() == '[') {
    name = name.substr(0, name.find(']') + 1);
  } else {
    name = name.substr(0, name.find(':'));
  }
  std::string lower(name);
  for (char& c : lower) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return lower == "localhost" || lower.rfind("127.", 0) == 0 || lower == "[::1]";
}

bool iequals(std::string_view a, std::string_view b) {
  if (a.size() != b.size()) return false;
  for (std::size_t i = 0; i < a.size(); ++i) {
    if (std::tolower(static_cast<unsigned char>(a[i])) !=
        std::tolower(static_cast<unsigned char>(b[i]))) {
      return false;
    }
  }
  return true;
}

std::optional<std::string> read_file(const std::filesystem::path& path) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) return std::nullopt;
  std::ifstream in(path, std::ios::binary);
  if (!in) return std::nullopt;
  std::ostringstream ss;
  ss << in.rdbuf();
  return std::move(ss).str();
}

// A WebSocket connection: an ordered queue of outgoing messages written one at a time.
struct WsSession : std::enable_shared_from_this<WsSession> {
  WsSession(beast::tcp_stream&& stream, std::size_t max_unread)
      : ws(std::move(stream)), max_unread_bytes(max_unread) {}

  // state frames are droppable: a browser that is behind skips them instead of lagging
  void send(std::shared_ptr<const std::string> message, bool droppable) {
    if (closed) return;
    if (droppable && queue.size() >= kMaxQueuedFrames) {
      ++dropped;
      return;
    }
    if (queued_bytes + message->size() > max_unread_bytes) {
      // a browser that asks and never reads (issue 17: 300 unread pictures, +60 MB) is cut
      std::fprintf(stderr,
                   "scaratwin web: a browser left %zu bytes of replies unread (limit %zu): "
                   "connection closed\n",
                   queued_bytes + message->size(), max_unread_bytes);
      closed = true;
      queue.clear();
      queued_bytes = 0;
      beast::error_code ignored;
      beast::get_lowest_layer(ws).socket().close(ignored);
      return;
    }
    queued_bytes += message->size();
    queue.push_back(std::move(message));
    if (!writing) write_next();
  }

  void write_next() {
    writing = true;
    ws.text(true);
    ws.async_write(asio::buffer(*queue.front()),
                   [self = shared_from_this()](beast::error_code ec, std::size_t) {
                     if (self->queue.empty()) {  // cut meanwhile
                       self->writing = false;
                       return;
                     }
                     self->queued_bytes -= self->queue.front()->size();
                     self->queue.pop_front();
                     if (ec) {
                       self->closed = true;
                       self->queue.clear();
                       self->queued_bytes = 0;
                       self->writing = false;
                       return;
                     }
                     if (self->queue.empty()) {
                       self->writing = false;
                     } else {
                       self->write_next();
                     }
                   });
  }

  websocket::stream<beast::tcp_stream> ws;
  std::deque<std::shared_ptr<const std::string>> queue;
  std::size_t queued_bytes = 0;  // of the messages in `queue`
  std::size_t max_unread_bytes;
  bool writing = false;
  bool closed = false;
  std::uint64_t dropped = 0;
};

}  // namespace

std::string default_web_root() { return data_paths().web_root.string(); }

struct WebServer::Impl {
  Impl(sim::World& w, WebOptions o, LinkStatusFn l)
      : world(w), options(std::move(o)), link(std::move(l)) {}

  sim::World& world;
  WebOptions options;
  LinkStatusFn link;
  std::filesystem::path root;
  std::unique_ptr<asio::io_context> io = std::make_unique<asio::io_context>(1);
  std::unique_ptr<tcp::acceptor> acceptor;
  asio::thread_pool worker{1};  // commands, in order; camera shots take tens of ms
  std::thread thread;
  std::uint16_t port = 0;
  std::string scene;                               // the "scene" message, built once
  std::vector<std::weak_ptr<WsSession>> sessions;  // io thread only
  std::atomic<std::size_t> client_count{0};
  std::atomic<std::uint64_t> command_count{0};
  std::mt19937_64 rng{std::random_device{}()};  // worker thread only
  bool stopped = false;

  Status listen() {
    beast::error_code ec;
    const auto address = asio::ip::make_address(options.bind_address, ec);
    if (ec) {
      return Error{static_cast<int>(WebError::kBadOption),
                   fmt::format("http bind address \"{}\" is not an IP address (e.g. 127.0.0.1 "
                               "or 0.0.0.0)",
                               options.bind_address)};
    }
    acceptor = std::make_unique<tcp::acceptor>(*io);
    const tcp::endpoint endpoint(address, options.port);
    acceptor->open(endpoint.protocol(), ec);
    if (!ec) acceptor->set_option(asio::socket_base::reuse_address(true), ec);
    if (!ec) acceptor->bind(endpoint, ec);
    if (!ec) acceptor->listen(asio::socket_base::max_listen_connections, ec);
    if (!ec) {
      port = acceptor->local_endpoint().port();
      return Ok{};
    }
    return Error{static_cast<int>(WebError::kBind),
                 fmt::format("cannot serve http on {}:{}: {} (choose another --http-port, or 0 "
                             "for any free port)",
                             options.bind_address, options.port, ec.message())};
  }

  void start() {
    asio::co_spawn(*io, accept_loop(), asio::detached);
    asio::co_spawn(*io, feed_loop(), asio::detached);
    thread = std::thread([this] {
      // handlers catch their own errors; this guards against a bug ending the process
      for (;;) {
        try {
          io->run();
          return;
        } catch (const std::exception& e) {
          std::fprintf(stderr, "scaratwin web: %s\n", e.what());
        }
      }
    });
  }

  void shutdown() {
    if (stopped) return;
    stopped = true;
    worker.stop();
    worker.join();
    io->stop();
    if (thread.joinable()) thread.join();
    sessions.clear();
    acceptor.reset();
    io.reset();  // destroys the pending coroutines and closes their sockets
  }

  // Accepts connections. When accepting fails (out of file descriptors: EMFILE, ENFILE,
  // ENOBUFS), the connection stays in the listen queue and an immediate retry would fail at
  // once, spinning the io thread (and starving the simulator's own threads): wait
  // kAcceptRetry between attempts instead, and say so once per episode.
  asio::awaitable<void> accept_loop() {
    bool failing = false;
    for (;;) {
      beast::error_code ec;
      tcp::socket socket = co_await acceptor->async_accept(asio::redirect_error(use_awaitable, ec));
      if (ec == asio::error::operation_aborted || !acceptor->is_open()) co_return;
      if (ec) {
        if (!failing) {
          failing = true;
          std::fprintf(stderr,
                       "scaratwin web: cannot accept a connection (%s); retrying every %d ms "
                       "until it works\n",
                       std::strerror(ec.value()), static_cast<int>(kAcceptRetry.count()));
        }
        asio::steady_timer pause(*io, kAcceptRetry);
        co_await pause.async_wait(asio::redirect_error(use_awaitable, ec));
        if (ec == asio::error::operation_aborted) co_return;
        continue;
      }
      if (failing) {
        failing = false;
        std::fprintf(stderr, "scaratwin web: accepting connections again\n");
      }
      asio::co_spawn(*io, serve(beast::tcp_stream(std::move(socket))), asio::detached);
    }
  }

  // HTTP requests on one connection until it closes or upgrades to a WebSocket.
  asio::awaitable<void> serve(beast::tcp_stream stream) {
    beast::flat_buffer buffer;
    for (;;) {
      beast::error_code ec;
      http::request_parser<http::string_body> parser;
      parser.body_limit(kMaxRequestBytes);
      stream.expires_after(std::chrono::seconds(30));
      co_await http::async_read(stream, buffer, parser, asio::redirect_error(use_awaitable, ec));
      if (ec) co_return;
      http::request<http::string_body> req = parser.release();
      const std::string_view target(req.target().data(), req.target().size());
      const std::string_view path = target.substr(0, target.find_first_of("?#"));
      if (websocket::is_upgrade(req)) {
        if (path != "/ws") {
          co_await respond(stream, req, http::status::not_found, "text/plain", "no such socket\n");
          co_return;
        }
        if (auto refusal = refuse_socket(req, target)) {
          std::fprintf(stderr, "scaratwin web: refused a WebSocket: %s\n", refusal->c_str());
          co_await respond(stream, req, http::status::forbidden, "text/plain", *refusal + "\n");
          co_return;
        }
        stream.expires_never();
        co_await websocket_session(std::move(stream), std::move(req));
        co_return;
      }
      if (path.rfind("/api/", 0) == 0 && !token_ok(target)) {
        co_await respond(stream, req, http::status::forbidden, "text/plain",
                         "this simulator needs its access token: ?token=...\n");
        co_return;
      }
      const bool keep = co_await handle_http(stream, req);
      if (!keep) {
        stream.socket().shutdown(tcp::socket::shutdown_send, ec);
        co_return;
      }
    }
  }

  bool token_ok(std::string_view target) const {
    if (options.token.empty()) return true;
    const auto given = query_value(target, "token");
    return given && *given == options.token;
  }

  // Why a WebSocket upgrade is refused, or nothing. Browsers always send Origin on a
  // WebSocket: a page of another site (Origin not this page's scheme://Host) may not drive
  // the simulator; without a token the Host must be this machine, so a hostile name that
  // resolves to 127.0.0.1 (DNS rebinding) is refused too. Clients that are not browsers send
  // no Origin.
  std::optional<std::string> refuse_socket(const http::request<http::string_body>& req,
                                           std::string_view target) const {
    const auto host_it = req.find(http::field::host);
    const std::string_view host =
        host_it == req.end() ? std::string_view()
                             : std::string_view(host_it->value().data(), host_it->value().size());
    if (!token_ok(target)) return "missing or wrong access token (?token=...)";
    if (options.token.empty() && !local_host(host)) {
      return fmt::format("Host '{}' is not this machine", host);
    }
    const auto origin_it = req.find(http::field::origin);
    if (origin_it != req.end()) {
      const std::string_view origin(origin_it->value().data(), origin_it->value().size());
      if (!iequals(origin, fmt::format("http://{}", host)) &&
          !iequals(origin, fmt::format("https://{}", host))) {
        return fmt::format("Origin '{}' is not this page's (http://{})", origin, host);
      }
    }
    return std::nullopt;
  }

  asio::awaitable<bool> respond(beast::tcp_stream& stream,
                                const http::request<http::string_body>& req, http::status status,
                                std::string_view type, std::string body) {
    http::response<http::string_body> res{status, req.version()};
    res.set(http::field::server, "scaratwin-sim");
    res.set(http::field::content_type, beast::string_view(type.data(), type.size()));
    res.set(http::field::cache_control, "no-cache");
    res.set("X-Content-Type-Options", "nosniff");
    res.keep_alive(req.keep_alive());
    const bool head = req.method() == http::verb::head;
    res.body() = std::move(body);
    res.prepare_payload();
    if (head) res.body().clear();
    beast::error_code ec;
    if (head) {
      http::response_serializer<http::string_body> sr{res};
      sr.split(true);
      co_await http::async_write_header(stream, sr, asio::redirect_error(use_awaitable, ec));
    } else {
      co_await http::async_write(stream, res, asio::redirect_error(use_awaitable, ec));
    }
    co_return !ec && req.keep_alive();
  }

  asio::awaitable<bool> handle_http(beast::tcp_stream& stream,
                                    const http::request<http::string_body>& req) {
    if (req.method() != http::verb::get && req.method() != http::verb::head) {
      co_return co_await respond(stream, req, http::status::method_not_allowed, "text/plain",
                                 "only GET and HEAD\n");
    }
    const std::string_view full(req.target().data(), req.target().size());
    const std::string_view target = full.substr(0, full.find_first_of("?#"));
    if (target == "/api/scene") {
      co_return co_await respond(stream, req, http::status::ok, "application/json", scene);
    }
    if (target == "/api/fleet") {
      if (!options.fleet) {
        co_return co_await respond(
            stream, req, http::status::not_found, "text/plain",
            "this simulator watches no fleet: start it with --mqtt mqtt://HOST[:PORT]\n");
      }
      co_return co_await respond(stream, req, http::status::ok, "application/json",
                                 options.fleet());
    }
    if (target == "/api/state") {
      co_return co_await respond(stream, req, http::status::ok, "application/json",
                                 state_json(true));
    }
    const auto path = resolve(root, target);
    if (!path) {
      co_return co_await respond(stream, req, http::status::bad_request, "text/plain",
                                 "bad path\n");
    }
    auto body = read_file(*path);
    if (!body) {
      co_return co_await respond(stream, req, http::status::not_found, "text/plain",
                                 fmt::format("{} not found\n", target));
    }
    co_return co_await respond(stream, req, http::status::ok, mime_type(*path), std::move(*body));
  }

  std::string state_json(bool with_path) {
    const sim::Snapshot snap = world.snapshot();
    const LinkStatus ls = link ? link() : LinkStatus{};
    StateExtras extras;
    extras.with_path = with_path;
    extras.clients = client_count.load();
    extras.world_speed = world.options().speed;
    if (options.robot_links) extras.robot_links = options.robot_links();
    return state_message(world.robot(), snap, ls, extras);
  }

  asio::awaitable<void> websocket_session(beast::tcp_stream stream,
                                          http::request<http::string_body> req) {
    auto session = std::make_shared<WsSession>(std::move(stream), options.max_unread_bytes);
    session->ws.set_option(websocket::stream_base::timeout::suggested(beast::role_type::server));
    session->ws.read_message_max(kMaxWsMessageBytes);
    beast::error_code ec;
    co_await session->ws.async_accept(req, asio::redirect_error(use_awaitable, ec));
    if (ec) co_return;
    sessions.push_back(session);
    ++client_count;
    session->send(std::make_shared<const std::string>(scene), false);
    // the first state with the path at once, so a new page draws everything
    session->send(std::make_shared<const std::string>(state_json(true)), false);
    beast::flat_buffer buffer;
    while (!session->closed) {
      buffer.clear();
      co_await session->ws.async_read(buffer, asio::redirect_error(use_awaitable, ec));
      if (ec) break;
      on_message(session, beast::buffers_to_string(buffer.data()));
    }
    session->closed = true;
    --client_count;
    std::erase_if(sessions, [&](const std::weak_ptr<WsSession>& w) {
      auto s = w.lock();
      return !s || s == session;
    });
  }

  void on_message(const std::shared_ptr<WsSession>& session, std::string text) {
    ++command_count;
    auto command = parse_command(text);
    if (!command) {
      session->send(
          std::make_shared<const std::string>(error_reply(std::nullopt, command.error().message)),
          false);
      return;
    }
    std::weak_ptr<WsSession> weak = session;
    asio::post(worker, [this, weak, c = *command] {
      std::string reply;
      try {
        reply = execute_command(world, c, rng);
      } catch (const std::exception& e) {
        reply = error_reply(c.id, fmt::format("command failed: {}", e.what()));
      }
      asio::post(*io, [weak, r = std::make_shared<const std::string>(std::move(reply))] {
        if (auto s = weak.lock()) s->send(r, false);
      });
    });
  }

  asio::awaitable<void> feed_loop() {
    asio::steady_timer timer(*io);
    const auto period = std::chrono::duration_cast<std::chrono::steady_clock::duration>(
        std::chrono::duration<double>(1.0 / options.feed_hz));
    auto next = std::chrono::steady_clock::now();
    std::uint64_t frame = 0;
    for (;;) {
      next += period;
      const auto now = std::chrono::steady_clock::now();
      if (next < now) next = now;  // no bursts after a stall
      timer.expires_at(next);
      beast::error_code ec;
      co_await timer.async_wait(asio::redirect_error(use_awaitable, ec));
      if (ec) co_return;
      if (sessions.empty()) continue;
      ++frame;
      const bool with_path =
          options.path_every <= 1 || frame % static_cast<std::uint64_t>(options.path_every) == 0;
      std::shared_ptr<const std::string> message;
      try {
        message = std::make_shared<const std::string>(state_json(with_path));
      } catch (const std::exception& e) {
        std::fprintf(stderr, "scaratwin web: feed: %s\n", e.what());
        continue;
      }
      for (const auto& w : sessions) {
        if (auto s = w.lock()) s->send(message, true);
      }
    }
  }
};

WebServer::WebServer() = default;

WebServer::~WebServer() {
  if (impl_) impl_->shutdown();
}

Result<std::unique_ptr<WebServer>> WebServer::create(sim::World& world, const WebOptions& options,
                                                     LinkStatusFn link) {
  if (!(options.feed_hz >= 1.0 && options.feed_hz <= 120.0)) {
    return Error{static_cast<int>(WebError::kBadOption),
                 fmt::format("feed rate {} Hz: must be in 1..120", options.feed_hz)};
  }
  std::error_code fec;
  const std::filesystem::path root = std::filesystem::absolute(options.root_dir, fec);
  if (fec || !std::filesystem::is_regular_file(root / "index.html", fec)) {
    if (options.root_dir == default_web_root() && !data_paths().problem.empty()) {
      return Error{
          static_cast<int>(WebError::kBadOption),
          missing_data_message("the browser page", root / "index.html") + " (or pass --web-root)"};
    }
    return Error{static_cast<int>(WebError::kBadOption),
                 fmt::format("web root \"{}\" has no index.html (build the page with the "
                             "scaratwin_web_assets target, or pass --web-root)",
                             options.root_dir)};
  }
  std::unique_ptr<WebServer> server(new WebServer());
  server->impl_ = std::make_shared<Impl>(world, options, std::move(link));
  Impl& impl = *server->impl_;
  impl.root = root;
  impl.scene = scene_message(world.robot(), world.geometry(), options.feed_hz,
                             static_cast<bool>(options.fleet));
  if (Status st = impl.listen(); !st) return st.error();
  impl.start();
  return server;
}

std::uint16_t WebServer::port() const { return impl_->port; }
std::size_t WebServer::clients() const { return impl_->client_count.load(); }
std::uint64_t WebServer::commands() const { return impl_->command_count.load(); }

}  // namespace scaratwin::web
