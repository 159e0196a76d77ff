// CompanionServer: the paper's companion TCP dialect onto a World (docs/protocol.md section 13).
#include <utility>  // before Boost headers (Boost 1.74 with g++ 12)

#include "scaratwin/sim/companion.hpp"

#include <atomic>
#include <cstdio>
#include <future>
#include <mutex>
#include <random>
#include <vector>

#include <fmt/format.h>
#include <boost/asio.hpp>

#include "scaratwin/core/units.hpp"
#include "scaratwin/sim/spawn.hpp"
#include "scaratwin/transport/io_thread.hpp"

namespace scaratwin::sim {

// ---- server ---------------------------------------------------------------------------------

namespace {

namespace asio = boost::asio;
using tcp = asio::ip::tcp;
using asio::use_awaitable;
using Kind = CompanionCommand::Kind;

// How a frame is shown in the log: printable ASCII as is, other bytes as \xNN, cut at 80.
std::string printable(std::string_view s) {
  std::string out;
  for (const char c : s.substr(0, 80)) {
    const auto u = static_cast<unsigned char>(c);
    if (u >= 0x20 && u <= 0x7e) {
      out += c;
    } else {
      out += fmt::format("\\x{:02x}", u);
    }
  }
  if (s.size() > 80) out += "...";
  return out;
}

}  // namespace

struct CompanionServer::Impl {
  World* world = nullptr;
  CompanionOptions options;
  std::shared_ptr<transport::IoThread> io;
  std::unique_ptr<tcp::acceptor> acceptor;
  std::uint16_t port = 0;
  std::mutex rng_mutex;
  std::mt19937_64 rng;
  std::atomic<std::uint64_t> frames{0}, refused{0}, applied{0}, images_sent{0}, clients{0};
  std::atomic<std::uint64_t> next_client{1};

  void log(const std::string& line) {
    if (options.log) {
      options.log(line);
    } else {
      std::fprintf(stderr, "scaratwin-sim: companion: %s\n", line.c_str());
    }
  }

  // Carries out one frame; appends any reply bytes (a Camera's PNG) to `out`.
  void handle(const std::string& who, std::string_view payload, std::string& out) {
    // counted once the frame has been carried out (or refused), so that a reader of the
    // counter sees its effect
    struct CountOnExit {
      std::atomic<std::uint64_t>& n;
      ~CountOnExit() { ++n; }
    } count{frames};
    auto cmd = parse_companion(payload, world->robot());
    if (!cmd) {
      ++refused;
      log(fmt::format("{}: refused '{}': {}", who, printable(payload), cmd.error().message));
      return;
    }
    switch (cmd->kind) {
      case Kind::kName:
        ++applied;
        log(fmt::format("{} is named '{}'", who, cmd->name));
        return;
      case Kind::kModRobot: {
        auto r = world->with_simulation([&](Simulation& s) -> Result<std::vector<JointWarning>> {
          if (s.mode() != Mode::kMirror) {
            return Error{static_cast<int>(SimError::kWrongMode),
                         "the simulator is in simulate mode (a hub is running a trajectory or "
                         "a prediction); ModRobot moves the robot in mirror mode only"};
          }
          return s.set_joints(cmd->q);
        });
        if (!r) {
          ++refused;
          log(fmt::format("{}: refused '{}': {}", who, printable(payload), r.error().message));
          return;
        }
        ++applied;
        return;
      }
      case Kind::kModGrab: {
        const GraspResult g = world->with_simulation([&](Simulation& s) {
          if (cmd->grab) return s.grip();
          s.release();
          return GraspResult{};
        });
        ++applied;
        if (cmd->grab) {
          log(g.holding ? fmt::format("{}: grasp: holding cube {}", who, g.cube_id)
                        : fmt::format("{}: grasp: nothing between the fingers", who));
        }
        return;
      }
      case Kind::kNewObj: {
        auto c = world->with_simulation([&](Simulation& s) {
          std::lock_guard lock(rng_mutex);
          return spawn_at_random(s, cmd->color, rng);
        });
        if (!c) {
          ++refused;
          log(fmt::format("{}: refused '{}': {}", who, printable(payload), c.error().message));
          return;
        }
        ++applied;
        log(fmt::format("{}: {} cube {} at x {:.1f} mm, y {:.1f} mm", who, color_name(c->color),
                        c->id, m_to_mm(c->pos_m[0]), m_to_mm(c->pos_m[1])));
        return;
      }
      case Kind::kCamera: {
        if (!world->has_camera()) {
          ++refused;
          log(fmt::format("{}: refused '{}': the simulator runs without a camera (--no-camera)",
                          who, printable(payload)));
          return;
        }
        auto png = world->shoot_png();
        if (!png) {
          ++refused;
          log(fmt::format("{}: camera failed: {}", who, png.error().message));
          return;
        }
        ++applied;
        ++images_sent;
        out.append(reinterpret_cast<const char*>(png->data()), png->size());
        return;
      }
    }
  }

  asio::awaitable<void> accept_loop() {
    for (;;) {
      boost::system::error_code ec;
      tcp::socket socket = co_await acceptor->async_accept(asio::redirect_error(use_awaitable, ec));
      if (ec == asio::error::operation_aborted || !acceptor->is_open()) co_return;
      if (ec) {
        // out of descriptors and the like: the connection stays queued; try again shortly
        asio::steady_timer pause(io->context(), std::chrono::milliseconds(50));
        co_await pause.async_wait(asio::redirect_error(use_awaitable, ec));
        if (ec == asio::error::operation_aborted) co_return;
        continue;
      }
      ++clients;
      asio::co_spawn(io->context(), serve(std::move(socket)), asio::detached);
    }
  }

  asio::awaitable<void> serve(tcp::socket socket) {
    boost::system::error_code ec;
    socket.set_option(tcp::no_delay(true), ec);
    const tcp::endpoint peer = socket.remote_endpoint(ec);
    std::string who =
        fmt::format("client {} ({}:{})", next_client++, peer.address().to_string(), peer.port());
    log(fmt::format("{} connected", who));
    CompanionFramer framer;
    std::vector<char> buf(4096);
    for (;;) {
      const std::size_t n = co_await socket.async_read_some(
          asio::buffer(buf), asio::redirect_error(use_awaitable, ec));
      if (ec) break;
      std::string out;
      framer.feed(
          std::string_view(buf.data(), n),
          [&](std::string_view payload) {
            if (payload.substr(0, 5) == "Name:" && payload.size() > 5) {
              handle(who, payload, out);
              who = fmt::format("{} '{}'", who, payload.substr(5));
              return;
            }
            handle(who, payload, out);
          },
          [&](const std::string& reason) {
            ++frames;
            ++refused;
            log(fmt::format("{}: {}", who, reason));
          });
      if (!out.empty()) {
        co_await asio::async_write(socket, asio::buffer(out),
                                   asio::redirect_error(use_awaitable, ec));
        if (ec) break;
      }
    }
    if (framer.pending() > 0) {
      log(fmt::format("{} disconnected in the middle of a frame ({} of {} bytes): dropped", who,
                      framer.pending() - 1, framer.expected()));
    } else {
      log(fmt::format("{} disconnected", who));
    }
  }
};

CompanionServer::CompanionServer() : impl_(std::make_unique<Impl>()) {}

CompanionServer::~CompanionServer() {
  if (!impl_->io) return;
  // the acceptor goes on the io thread (its pending accept ends with operation_aborted); the
  // io thread's end then destroys the sessions with their sockets
  std::promise<void> closed;
  asio::post(impl_->io->context(), [this, &closed] {
    impl_->acceptor.reset();
    closed.set_value();
  });
  closed.get_future().wait();
  impl_->io.reset();
}

Result<std::unique_ptr<CompanionServer>> CompanionServer::create(World& world,
                                                                 const CompanionOptions& options) {
  std::unique_ptr<CompanionServer> s(new CompanionServer());
  Impl& impl = *s->impl_;
  impl.world = &world;
  impl.options = options;
  impl.rng.seed(options.spawn_seed);
  boost::system::error_code ec;
  const auto address = asio::ip::make_address(options.bind_address, ec);
  if (ec) {
    return Error{static_cast<int>(SimError::kBadArgument),
                 fmt::format("companion bind address '{}' is not an IP address (e.g. 127.0.0.1)",
                             options.bind_address)};
  }
  impl.io = transport::IoThread::create("scaratwin-companion");
  impl.acceptor = std::make_unique<tcp::acceptor>(impl.io->context());
  const tcp::endpoint endpoint(address, options.port);
  impl.acceptor->open(endpoint.protocol(), ec);
  if (!ec) impl.acceptor->set_option(asio::socket_base::reuse_address(true), ec);
  if (!ec) impl.acceptor->bind(endpoint, ec);
  if (!ec) impl.acceptor->listen(asio::socket_base::max_listen_connections, ec);
  if (ec) {
    return Error{static_cast<int>(SimError::kBadArgument),
                 fmt::format("cannot serve the companion dialect on {}:{}: {} (choose another "
                             "--companion-port, or 0 for any free port)",
                             options.bind_address, options.port, ec.message())};
  }
  impl.port = impl.acceptor->local_endpoint().port();
  asio::co_spawn(impl.io->context(), impl.accept_loop(), asio::detached);
  return s;
}

std::uint16_t CompanionServer::port() const { return impl_->port; }

CompanionCounters CompanionServer::counters() const {
  CompanionCounters c;
  c.frames = impl_->frames;
  c.refused = impl_->refused;
  c.applied = impl_->applied;
  c.images_sent = impl_->images_sent;
  c.clients = impl_->clients;
  return c;
}

}  // namespace scaratwin::sim
