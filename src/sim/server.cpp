// SimServer: protocol dispatch of the virtual link onto a World.
#include <utility>  // before Boost headers (Boost 1.74 with g++ 12)

#include "scaratwin/sim/server.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <mutex>
#include <optional>
#include <string_view>

#include <fmt/format.h>

#include "admission.hpp"
#include "scaratwin/protocol/codec.hpp"
#include "scaratwin/transport/io_thread.hpp"
#include "scaratwin/transport/tcp.hpp"

namespace scaratwin::sim {
namespace {

namespace proto = scaratwin::protocol;
namespace core = scaratwin::protocol::core;

constexpr const char* kDeviceName = "scaratwin-sim";
constexpr const char* kSoftwareVersion = "0.1.0";
// ER,18 details (docs/protocol.md section 6)
constexpr std::int32_t kAccessToken = 1;       // token missing or wrong
constexpr std::int32_t kAccessInUse = 2;       // another client controls the simulator
constexpr std::int32_t kAccessObserver = 3;    // an observer may only query
constexpr std::int32_t kAccessOtherRobot = 4;  // a controller of one robot addressed another

std::uint32_t wrap_us(double seconds) {
  return static_cast<std::uint32_t>(static_cast<std::uint64_t>(std::llround(seconds * 1e6)));
}

proto::SimMode to_wire(Mode m) {
  return m == Mode::kMirror ? proto::SimMode::kMirror : proto::SimMode::kSimulate;
}

}  // namespace

struct SimServer::Impl {
  World& world;
  ServerOptions options;
  std::shared_ptr<transport::IoThread> io;
  std::unique_ptr<transport::TcpServer> link;
  std::mutex handle_mutex;  // handle_line() from the io thread or from a test
  proto::TcpToSimDecoder decoder;
  std::uint16_t state_seq = 0;
  // per robot: the sender's time of its prediction stream's first target
  std::vector<std::uint32_t> stream_first_us;
  std::uint64_t shots = 0;
  std::atomic<std::uint64_t> packets{0}, errors_sent{0}, joint_frames{0}, images_sent{0},
      warnings_sent{0};

  // per robot: the hash of its description, which the hello reply carries
  std::vector<std::string> descriptions;

  // Who controls what (admission.hpp, docs/security.md).
  ControllerClaims claims;

  Impl(World& w, ServerOptions o)
      : world(w),
        options(std::move(o)),
        stream_first_us(static_cast<std::size_t>(w.robot_count()), 0),
        claims(w.robot_count()) {
    w.with_simulation([&](Simulation& s) {
      for (int r = 0; r < s.robot_count(); ++r)
        descriptions.push_back(description_hash(s.robot(r)));
    });
  }

  // The hello reply: with the description hash (of the robot the hello names, else robot 0's)
  // when the hub's hello carried its own (a v1 hub gets a v1 reply).
  proto::PeerHello peer_hello(const proto::Hello& m) const {
    std::size_t r = m.robot ? static_cast<std::size_t>(*m.robot) : 0;
    if (r >= descriptions.size()) r = 0;
    return proto::PeerHello{core::kProtocolVersion, kDeviceName, kSoftwareVersion,
                            m.description.empty() ? std::string{} : descriptions.at(r)};
  }

  void put(std::string& out, const proto::TcpFromSim& m) {
    if (std::holds_alternative<proto::ErrorReply>(m)) ++errors_sent;
    if (Status st = proto::append(out, m); !st) {
      // a value the wire cannot carry (e.g. a cube that flew off to infinity): say so
      ++errors_sent;
      (void)proto::append(out,
                          proto::TcpFromSim(proto::ErrorReply{core::kErrInternal, std::nullopt}));
    }
  }
  void error(std::string& out, std::int32_t code, std::optional<std::int32_t> detail = {}) {
    put(out, proto::ErrorReply{code, detail});
  }
  void warnings(std::string& out, const std::vector<JointWarning>& ws) {
    for (const JointWarning& w : ws) {
      put(out, proto::JointWarning{w.joint + 1, w.value, w.robot});
      ++warnings_sent;
    }
  }

  void on(std::string& out, const proto::Hello& m, std::optional<int> claim) {
    if (m.version != core::kProtocolVersion) {
      error(out, core::kErrVersion, core::kProtocolVersion);
      return;
    }
    if (m.robot && *m.robot >= world.robot_count()) {
      error(out, core::kErrNoRobot, world.robot_count());
      return;
    }
    if (claim && m.robot != claim) {
      // a controller of one robot does not become another's by saying hello again
      error(out, core::kErrAccess, kAccessOtherRobot);
      return;
    }
    if (options.on_new_stream) {
      if (m.robot) {
        options.on_new_stream(*m.robot);
      } else {
        for (int r = 0; r < world.robot_count(); ++r) options.on_new_stream(r);
      }
    }
    // a new hub: a homing phase a hub left unfinished (it died) ends here
    world.with_simulation([&](Simulation& s) {
      if (m.robot) {
        s.restart_limit_warnings(*m.robot);
      } else {
        s.restart_limit_warnings();
      }
    });
    const std::string& mine = descriptions.at(static_cast<std::size_t>(m.robot.value_or(0)));
    if (!m.description.empty() && m.description != mine) {
      std::fprintf(stderr,
                   "scaratwin-sim: a hub built for robot description %s said hello; this "
                   "simulator runs description %s (the hub refuses it: start both with the same "
                   "--config)\n",
                   m.description.c_str(), mine.c_str());
    }
    put(out, peer_hello(m));
  }
  void on(std::string& out, const proto::Ping& m) { put(out, proto::Ack{"PI", m.token}); }
  // A JD/TJ with a joint no robot can have (implausible_joint()) is refused with one
  // ER,11,<field index> (d1 is field 2) and nothing is applied.
  bool refuse_implausible(std::string& out, const JointVector& q, int robot) {
    const int j =
        world.with_simulation([&](Simulation& s) { return implausible_joint(s.robot(robot), q); });
    if (j < 0) return false;
    error(out, core::kErrBadValue, 2 + j);
    return true;
  }
  void on(std::string& out, const proto::JointData& m) {
    if (refuse_implausible(out, m.q, m.robot)) return;
    auto r = world.with_simulation([&](Simulation& s) { return s.set_joints(m.q, m.robot); });
    reply_joint(out, r, m.seq, m.t_us, m.q, m.robot);
  }
  void on(std::string& out, const proto::JointTargets& m) {
    // paced: a servo target now; --speed max: a timed target of a prediction stream, played
    // in lockstep as fast as possible (t_us offsets from the stream's first target)
    const bool stream = world.options().speed == 0.0;
    if (refuse_implausible(out, m.q, m.robot)) return;
    auto r = world.with_simulation([&](Simulation& s) {
      if (!stream) return s.hold(m.q, m.robot);
      std::uint32_t& first_us = stream_first_us[static_cast<std::size_t>(m.robot)];
      if (!s.stream_open(m.robot)) first_us = m.t_us;
      return s.stream_target(static_cast<std::uint32_t>(m.t_us - first_us) * 1e-6, m.q, m.robot);
    });
    reply_joint(out, r, m.seq, m.t_us, m.q, m.robot);
  }
  void reply_joint(std::string& out, const Result<std::vector<JointWarning>>& r, std::uint16_t seq,
                   std::uint32_t t_us, const JointVector& q, int robot) {
    if (!r) {
      error(out, r.error().code == static_cast<int>(SimError::kWrongMode) ? core::kErrBusy
                                                                          : core::kErrBadValue);
      return;
    }
    ++joint_frames;
    warnings(out, *r);
    const std::int64_t applied_us = transport::steady_now_us();
    if (options.on_joint_frame) {
      options.on_joint_frame(JointFrame{seq, t_us, q, applied_us, robot});
    }
    put(out, proto::JointApplied{seq, static_cast<std::uint32_t>(applied_us), robot});
  }
  void on(std::string& out, const proto::SetMode& m) {
    if (options.on_new_stream) options.on_new_stream(m.robot);
    world.with_simulation([&](Simulation& s) {
      s.set_mode(m.mode == proto::SimMode::kMirror ? Mode::kMirror : Mode::kSimulate, m.robot);
    });
    put(out, proto::Ack{"MD", std::nullopt});
  }
  void on(std::string& out, const proto::SetTwinPhase& m) {
    world.with_simulation([&](Simulation& s) {
      s.set_limit_warnings(m.phase != proto::TwinPhase::kHoming, m.robot);
    });
    if (options.on_twin_phase && m.robot == 0) {  // the page's twin phase is robot 0's
      options.on_twin_phase(m.phase == proto::TwinPhase::kNone ? std::string()
                                                               : proto::phase_name(m.phase));
    }
    put(out, proto::Ack{"TW", std::nullopt});
  }
  void on(std::string& out, const proto::Grasp& m) {
    const GripperStateValue g = world.with_simulation([&](Simulation& s) {
      if (s.stream_open(m.robot)) {
        // at the stream's last target; the reply tells the state it will have then
        s.queue_gripper(m.close ? GripperAction::kGrip : GripperAction::kRelease, m.robot);
        return GripperStateValue{m.close, s.held_cube(m.robot)};
      }
      if (m.close) {
        (void)s.grip(m.robot);
      } else {
        s.release(m.robot);
      }
      return GripperStateValue{s.gripper_closed(m.robot), s.held_cube(m.robot)};
    });
    put(out, proto::GripperState{g.closed, g.held, m.robot});
  }
  struct GripperStateValue {
    bool closed;
    int held;
  };
  void on(std::string& out, const proto::CameraShoot& m) {
    if (!world.has_camera()) {
      error(out, core::kErrInternal);
      return;
    }
    if (m.width_px < 0 || m.width_px > world.max_image_width_px()) {
      error(out, core::kErrBadValue, 0);
      return;
    }
    if (m.height_px < 0 || m.height_px > world.max_image_height_px() ||
        (m.width_px == 0) != (m.height_px == 0)) {
      error(out, core::kErrBadValue, 1);
      return;
    }
    auto png = world.shoot_png(m.width_px, m.height_px);
    if (!png) {
      std::fprintf(stderr, "scaratwin-sim: camera: %s\n", png.error().message.c_str());
      error(out, core::kErrInternal);
      return;
    }
    if (!options.save_images_dir.empty()) save(*png);
    ++images_sent;
    put(out, proto::Image{std::move(*png)});
  }
  void save(const std::vector<std::uint8_t>& png) {
    const auto path =
        std::filesystem::path(options.save_images_dir) / fmt::format("shot_{:05d}.png", shots++);
    std::FILE* f = std::fopen(path.c_str(), "wb");
    if (f == nullptr || std::fwrite(png.data(), 1, png.size(), f) != png.size()) {
      std::fprintf(stderr, "scaratwin-sim: cannot write %s\n", path.c_str());
    }
    if (f != nullptr) std::fclose(f);
  }
  void on(std::string& out, const proto::SpawnCube& m) {
    auto r =
        world.with_simulation([&](Simulation& s) { return s.spawn_cube(m.color, m.x_m, m.y_m); });
    if (!r) {
      const int code = r.error().code;
      if (code == static_cast<int>(SimError::kPoolExhausted)) {
        error(out, core::kErrQueueFull, 0);
      } else {
        error(out, core::kErrBadValue, 1);
      }
      return;
    }
    put(out, proto::Ack{"SC", r->id});
  }
  void on(std::string& out, const proto::ResetScene&) {
    Status st = world.with_simulation([](Simulation& s) {
      s.reset_scene();
      for (int r = 0; r < s.robot_count(); ++r) {
        if (Status one = s.reset_robot(r); !one) return one;
      }
      return Status{Ok{}};
    });
    if (!st) {
      error(out, core::kErrInternal);
      return;
    }
    put(out, proto::Ack{"RS", std::nullopt});
  }
  void on(std::string& out, const proto::QueryObjects& m) {
    std::vector<CubeState> cubes;
    bool found = true;
    world.with_simulation([&](Simulation& s) {
      if (m.id) {
        auto c = s.cube(*m.id);
        found = c.ok();
        if (found) cubes.push_back(*c);
      } else {
        cubes = s.cubes();
      }
    });
    if (!found) {
      error(out, core::kErrBadValue, 0);
      return;
    }
    for (const CubeState& c : cubes) {
      const auto& q = c.quat_wxyz;
      const double yaw =
          std::atan2(2.0 * (q[0] * q[3] + q[1] * q[2]), 1.0 - 2.0 * (q[2] * q[2] + q[3] * q[3]));
      put(out, proto::ObjectPose{c.id, c.color, c.pos_m[0], c.pos_m[1], c.pos_m[2], yaw});
    }
    put(out, proto::Ack{"OP", static_cast<std::int32_t>(cubes.size())});
  }
  void on(std::string& out, const proto::QueryState& m) {
    proto::SimState st;
    st.robot = m.robot;
    world.with_simulation([&](Simulation& s) {
      st.seq = state_seq++;
      st.t_us = wrap_us(s.time_s());
      st.q = s.joints(m.robot);
      st.grip_closed = s.gripper_closed(m.robot);
      st.held_id = s.held_cube(m.robot);
      st.mode = to_wire(s.mode(m.robot));
    });
    put(out, st);
  }
  void on(std::string& out, const proto::QueryContacts&) {
    const Simulation::ArmContacts c =
        world.with_simulation([](Simulation& s) { return s.arm_contacts(); });
    put(out, proto::ArmContacts{c.count, c.robot_a, c.robot_b, wrap_us(c.t_s)});
  }
  void on(std::string& out, const proto::Stop& m) {
    world.with_simulation([&](Simulation& s) { s.stop(m.robot); });
    put(out, proto::Ack{"SP", std::nullopt});
  }

  // The observer's side: queries only, each line answered (docs/security.md).
  std::string handle_observer(const transport::Frame& frame) {
    std::string out;
    if (frame.kind == transport::FrameKind::kOverlong) {
      error(out, core::kErrLineTooLong, 512);
      return out;
    }
    if (frame.kind != transport::FrameKind::kLine) {
      error(out, core::kErrAccess, kAccessObserver);
      return out;
    }
    std::lock_guard lock(handle_mutex);
    proto::TcpToSimDecoder d;
    std::string framed = frame.line;
    framed += '\n';
    d.feed(framed, [&](proto::Decoded<proto::TcpToSim>&& m) {
      if (auto* e = std::get_if<proto::DecodeError>(&m)) {
        error(out, e->code, e->detail);
        return;
      }
      const auto& msg = std::get<proto::TcpToSim>(m);
      if (const auto* hi = std::get_if<proto::Hello>(&msg)) {
        if (hi->version != core::kProtocolVersion) {
          error(out, core::kErrVersion, core::kProtocolVersion);
        } else {
          put(out, peer_hello(*hi));
        }
      } else if (std::holds_alternative<proto::Ping>(msg) ||
                 std::holds_alternative<proto::QueryState>(msg) ||
                 std::holds_alternative<proto::QueryContacts>(msg) ||
                 std::holds_alternative<proto::QueryObjects>(msg)) {
        std::visit([&](const auto& q) { dispatch(out, q, std::nullopt); }, msg);
      } else {
        error(out, core::kErrAccess, kAccessObserver);
      }
    });
    if (out.empty()) error(out, core::kErrBadCharacter, 0);
    return out;
  }

  static transport::AdmissionDecision decision(transport::Admission a, std::string reply = {}) {
    transport::AdmissionDecision d;
    d.admission = a;
    d.reply = std::move(reply);
    return d;
  }

  // Judges a new connection on its first line (transport::AdmitFn).
  transport::AdmissionDecision admit(std::string_view first, bool complete, const std::string& peer,
                                     bool controller) {
    using transport::Admission;
    if (looks_like_http(first)) {
      std::fprintf(stderr,
                   "scaratwin-sim: closed a connection from %s: it sent an HTTP request "
                   "(\"%.40s\"), not the simulator protocol; nothing of it was run\n",
                   peer.c_str(), std::string(first.substr(0, 40)).c_str());
      return decision(Admission::kRefuse);
    }
    if (!complete) {
      // silent for first_line_timeout: it would hold the simulator without saying who it is
      std::fprintf(stderr,
                   "scaratwin-sim: closed a connection from %s: no complete line within 10 s\n",
                   peer.c_str());
      return decision(Admission::kRefuse);
    }
    std::optional<proto::Hello> hello;
    {
      proto::TcpToSimDecoder d;
      std::string framed(first);
      framed += '\n';
      d.feed(framed, [&](proto::Decoded<proto::TcpToSim>&& m) {
        if (auto* msg = std::get_if<proto::TcpToSim>(&m)) {
          if (auto* hi = std::get_if<proto::Hello>(msg)) hello = *hi;
        }
      });
    }
    auto refuse = [&](int detail, const char* why) {
      std::fprintf(stderr, "scaratwin-sim: refused a connection from %s: %s\n", peer.c_str(), why);
      std::string reply;
      error(reply, core::kErrAccess, detail);
      return decision(Admission::kRefuse, std::move(reply));
    };
    if (!options.token.empty() && (!hello || hello->token != options.token)) {
      return refuse(kAccessToken,
                    hello && !hello->token.empty()
                        ? "wrong token"
                        : "no token (this simulator needs HI,1,control,<token>, first)");
    }
    if (hello && hello->role == "observe") return decision(Admission::kObserve);
    const std::optional<int> robot = hello ? hello->robot : std::nullopt;
    if (robot && *robot >= world.robot_count()) {
      // its hello is answered ER,19 by the handler; it holds nothing
      std::string reply;
      error(reply, core::kErrNoRobot, world.robot_count());
      std::fprintf(stderr, "scaratwin-sim: refused a connection from %s: no robot %d here\n",
                   peer.c_str(), *robot);
      return decision(Admission::kRefuse, std::move(reply));
    }
    switch (claims.claim(robot, controller)) {
      case ControllerClaims::Verdict::kControl:
        return decision(Admission::kControl);
      case ControllerClaims::Verdict::kServe: {
        const int r = *robot;
        std::fprintf(stderr, "scaratwin-sim: %s controls robot %d\n", peer.c_str(), r);
        transport::AdmissionDecision d = decision(Admission::kServe);
        d.serve = [this, r](const transport::Frame& f) { return handle_frame(f.kind, f.line, r); };
        d.closed = [this, r] { claims.release(r); };
        return d;
      }
      case ControllerClaims::Verdict::kInUse:
        break;
    }
    return refuse(kAccessInUse, robot ? "another client controls that robot (an observer says "
                                        "HI,1,observe,)"
                                      : "another client controls the simulator (an observer "
                                        "says HI,1,observe,)");
  }

  // A robot-addressed packet (protocol v2) for a robot the simulator does not have is
  // refused with ER,19,<robots it has>, and nothing of it is applied.
  // A controller of one robot (`claim`) may command that robot only, query every robot, and
  // not reset the scene of a workcell (that moves every robot): ER,18,4 otherwise.
  template <typename M>
  void dispatch(std::string& out, const M& m, std::optional<int> claim) {
    if constexpr (std::is_same_v<M, proto::Hello>) {
      on(out, m, claim);
      return;
    } else {
      if constexpr (requires { m.robot; }) {
        if (m.robot < 0 || m.robot >= world.robot_count()) {
          error(out, core::kErrNoRobot, world.robot_count());
          return;
        }
        if (claim && m.robot != *claim && !std::is_same_v<M, proto::QueryState>) {
          error(out, core::kErrAccess, kAccessOtherRobot);
          return;
        }
      }
      if constexpr (std::is_same_v<M, proto::ResetScene>) {
        if (claim && world.robot_count() > 1) {
          error(out, core::kErrAccess, kAccessOtherRobot);
          return;
        }
      }
      on(out, m);
    }
  }

  // One frame of a controlling connection -> its reply; `claim`: the robot it drives.
  std::string handle_frame(transport::FrameKind kind, const std::string& line,
                           std::optional<int> claim) {
    std::string reply;
    switch (kind) {
      case transport::FrameKind::kLine:
        return handle(line, claim);
      case transport::FrameKind::kOverlong:
        ++packets;
        error(reply, core::kErrLineTooLong, 512);
        break;
      case transport::FrameKind::kBinary:
        // an image sent to the simulator: IM is not a hub -> simulator code
        ++packets;
        error(reply, core::kErrUnknownCode);
        break;
      case transport::FrameKind::kOversize:
        ++packets;
        error(reply, core::kErrPayloadTooLarge);
        break;
    }
    return reply;
  }

  std::string handle(const std::string& line, std::optional<int> claim) {
    std::lock_guard lock(handle_mutex);
    ++packets;
    std::string out;
    std::string framed = line;
    framed += '\n';
    int seen = 0;
    decoder.feed(framed, [&](proto::Decoded<proto::TcpToSim>&& d) {
      ++seen;
      if (auto* e = std::get_if<proto::DecodeError>(&d)) {
        error(out, e->code, e->detail);
        return;
      }
      std::visit([&](const auto& m) { dispatch(out, m, claim); }, std::get<proto::TcpToSim>(d));
    });
    if (seen == 0) {
      // an incomplete line cannot happen here; keep the one-reply rule anyway
      decoder.reset();
      error(out, core::kErrBadCharacter, 0);
    }
    return out;
  }
};

SimServer::SimServer(World& world, ServerOptions options)
    : impl_(std::make_unique<Impl>(world, std::move(options))) {}

SimServer::~SimServer() {
  if (impl_->link) impl_->link->close();
}

Result<std::unique_ptr<SimServer>> SimServer::create(World& world, const ServerOptions& options) {
  for (char c : options.token) {
    const bool ok = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') ||
                    c == '_' || c == '.' || c == '-';
    if (!ok || options.token.size() > 32) {
      return Error{static_cast<int>(SimError::kBadArgument),
                   "access token: expected 1..32 characters of A-Z a-z 0-9 _ . -"};
    }
  }
  std::unique_ptr<SimServer> s(new SimServer(world, options));
  Impl& impl = *s->impl_;
  if (!options.save_images_dir.empty()) {
    std::error_code ec;
    std::filesystem::create_directories(options.save_images_dir, ec);
    if (ec) {
      return Error{static_cast<int>(SimError::kBadArgument),
                   fmt::format("--save-images '{}': {}", options.save_images_dir, ec.message())};
    }
  }
  impl.io = transport::IoThread::create("scaratwin-sim-io");
  transport::TcpServerOptions o;
  o.bind_address = options.bind_address;
  o.port = options.port;
  o.admit = [&impl](std::string_view first, bool complete, const std::string& peer,
                    bool controller) { return impl.admit(first, complete, peer, controller); };
  o.observe = [&impl](const transport::Frame& f) { return impl.handle_observer(f); };
  auto link = transport::TcpServer::create(o, impl.io);
  if (!link) return link.error();
  impl.link = std::move(*link);
  transport::TcpServer* raw = impl.link.get();
  impl.link->set_packet_handler([&impl, raw](transport::RxPacket&& p) {
    std::string reply = impl.handle_frame(p.kind, p.line, impl.claims.session_robot());
    if (!reply.empty()) (void)raw->send(std::move(reply));
  });
  return s;
}

std::uint16_t SimServer::port() const { return impl_->link->port(); }
bool SimServer::peer_connected() const { return impl_->link->connected(); }

bool SimServer::robot_controlled(int robot) const {
  return impl_->claims.controlled(robot, impl_->link->connected());
}

ServerCounters SimServer::counters() const {
  ServerCounters c;
  c.packets = impl_->packets;
  c.errors_sent = impl_->errors_sent;
  c.joint_frames = impl_->joint_frames;
  c.images_sent = impl_->images_sent;
  c.warnings_sent = impl_->warnings_sent;
  return c;
}

std::string SimServer::handle_line(const std::string& line) {
  return impl_->handle(line, std::nullopt);
}

}  // namespace scaratwin::sim
