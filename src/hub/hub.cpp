#include "scaratwin/hub/hub.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <thread>

#include <fmt/format.h>

#include "hub_internal.hpp"
#include "scaratwin/core/overloaded.hpp"
#include "scaratwin/core/units.hpp"
#include "scaratwin/hub/analysis.hpp"

namespace scaratwin {

namespace pr = protocol;
namespace tr = transport;
using hub_detail::hub_error;
using hub_detail::ms;
using std::chrono::milliseconds;

namespace {

// Plan time ahead of a report's progress along the plan in which the desync check looks for
// the next report's nearest point of the plan: far more than a robot on its path moves between
// two reports, short enough not to confuse a descent with the lift that comes back up.
constexpr double kDesyncWindowS = 1.5;

constexpr const char* kInterrupted = "interrupted";

// A robot link silent during a trajectory ends it whatever the silence was after the reply
// timeout (HubOptions::reply_timeout_s, the same rule as for a request), and never before
// this: the robot's queue (at most 63 points of 20 ms) has run out by then on a cut link. A
// shorter limit ended healthy moves of an emulated robot that a busy host did not run for
// 1.5 s (its clock stood still: a stalled robot moves no further than its host lets it).
constexpr double kRobotSilenceAbortMinS = 1.5;
// A watchdog pass this much later than due: the hub itself was not running.
constexpr std::int64_t kLatePassUs = 100000;
// Longest time between two trajectory points sent to the robot (the firmware's limit is 5 s).
constexpr double kLongestPointS = 4.0;

// The hub's hello to the simulator: with a token it says it means to control (security.md).
// `description`: the hash of the hub's robot description, or "" for a v1 hello. A described
// hello of a controlling hub names its robot: the simulator lets one controller drive each
// robot of its workcell.
pr::Hello sim_hello(const HubOptions& o, const std::string& description) {
  const std::string role =
      !o.sim_role.empty() ? o.sim_role : (o.sim_token.empty() ? "" : "control");
  pr::Hello h{pr::kProtocolVersion, role, o.sim_token, description, std::nullopt};
  if (!description.empty() && role != "observe") h.robot = o.sim_robot;
  return h;
}

std::string no_sim_robot(const HubOptions& o) {
  return fmt::format(
      "the simulator at {}:{} has no robot {} (it counts from 0): start it with the workcell "
      "this robot belongs to",
      o.sim_host, o.sim_port, o.sim_robot);
}

// A v1 peer does not know the hello's description field: it answers ER 4 (wrong field count).
bool refused_described_hello(const Error& e) {
  return e.code == protocol_error_code(pr::core::kErrWrongFieldCount);
}

// Checks the description hash of a peer's hello against the hub's (docs/protocol.md section
// 11): a peer that sends none is a v1 peer and accepted.
Status check_description(const pr::PeerHello& hi, const std::string& peer, const std::string& own,
                         const HubOptions& o, const char* fix) {
  if (hi.description.empty() || hi.description == own) return Ok{};
  const std::string source =
      o.description_source.empty() ? std::string{} : fmt::format(" ({})", o.description_source);
  return hub_error(fmt::format("{} was built for robot description {}, this hub for {}{}: {}", peer,
                               hi.description, own, source, fix));
}

// What an ER,18 to the hub's hello means (docs/protocol.md section 6), from the refusal text.
std::string access_refusal(const std::string& message, const HubOptions& o) {
  if (message.find("detail 1") != std::string::npos) {
    return o.sim_token.empty() ? "it needs its access token (--sim-token or SCARATWIN_TOKEN)"
                               : "wrong access token";
  }
  if (message.find("detail 2") != std::string::npos) {
    return "another client controls it (stop that hub first)";
  }
  return message;
}

}  // namespace

Hub::Hub(const RobotModel& model, const HubOptions& options, TwinDb* db)
    : model_(model),
      options_(options),
      db_(db),
      report_dir_(homed_directions(model)),
      sample_clock_(100, state_report_wire_s(std::max(1u, options.baud))) {}

Hub::~Hub() {
  {
    std::lock_guard<std::mutex> lock(mu_);
    watchdog_quit_ = true;
    cv_.notify_all();
  }
  if (watchdog_.joinable()) watchdog_.join();
  // statements and channels first (they hold the links' handlers), then the links, then the
  // io thread.
  statements_.reset();
  robot_ = nullptr;
  if (robot_if_) robot_if_->shutdown();
  sim_.reset();
  tcp_.reset();
  io_.reset();
  if (db_ != nullptr) (void)db_->flush();
}

Result<std::unique_ptr<Hub>> Hub::connect(const RobotModel& model, const HubOptions& o,
                                          TwinDb* db) {
  return connect(model, serial_robot(o.serial_device, o.baud), o, db);
}

Result<std::unique_ptr<Hub>> Hub::connect(const RobotModel& model,
                                          std::unique_ptr<RobotInterface> robot,
                                          const HubOptions& o, TwinDb* db) {
  if (!robot) return hub_error("no robot to connect to");
  std::unique_ptr<Hub> t(new Hub(model, o, db));
  t->io_ = tr::IoThread::create("scaratwin-hub");
  t->robot_if_ = std::move(robot);
  tr::TcpClientOptions to;
  to.host = o.sim_host;
  to.port = o.sim_port;
  auto tcp = tr::TcpClient::create(to, t->io_);
  if (!tcp) return tcp.error();
  t->tcp_ = std::move(*tcp);
  if (Status s = t->robot_if_->configure(t->io_, ms(o.hello_timeout_s)); !s) return s.error();
  if (Status s = t->tcp_->wait_connected(ms(o.hello_timeout_s)); !s) {
    return hub_error(fmt::format("virtual robot: no simulator at {}:{}: {}", o.sim_host, o.sim_port,
                                 s.error().message));
  }
  t->robot_ = &t->robot_if_->channel();
  // the simulator link's heartbeat: a simulator that hangs with its socket open (stopped,
  // deadlocked) is noticed within 1.2 s like one that died (docs/protocol.md section 11); a
  // camera shot may take its own timeout (render and PNG on a busy machine)
  tr::ChannelOptions sim_channel;
  sim_channel.heartbeat = milliseconds(200);
  sim_channel.dead_after = milliseconds(1000);
  sim_channel.slow_codes = {"CS"};
  t->sim_ = std::make_unique<tr::SimChannel>(*t->tcp_, sim_channel);
  tr::TwinOptions so_statements;
  so_statements.reply_timeout = ms(o.reply_timeout_s);
  // the robot's periodic reports share the 115200 baud line with the credit polls' replies;
  // polling every 100 ms keeps its 15-point queue (0.3 s at 20 ms a point) topped up without
  // crowding the reports out of its transmit buffer.
  so_statements.credit_poll = std::chrono::milliseconds(100);
  so_statements.robot = o.sim_robot;
  t->statements_ = std::make_unique<tr::Twin>(t->model_, t->robot_, t->sim_.get(), so_statements);
  Hub* raw = t.get();
  t->sim_->set_state_handler([raw](tr::LinkState s) { raw->on_sim_link(s); });
  t->robot_->set_unsolicited_handler([raw](pr::SerialFromDevice&& m, const tr::RxPacket& rx) {
    raw->on_robot_packet(std::move(m), rx);
  });

  // hellos: a real board may still be in its bootloader, so retry until the timeout.
  // The hello carries the hub's description hash; the robot answers with its own. A v1 robot
  // refuses the field (then it gets a v1 hello) or answers without a hash. A hello without
  // one may also be the robot's own after a reset (a real board resets when the port opens),
  // so only a second one in a row counts as a v1 robot's.
  const std::string description = description_hash(model);
  const auto deadline = std::chrono::steady_clock::now() + ms(o.hello_timeout_s);
  bool described = true;
  int undescribed_replies = 0;
  for (;;) {
    auto r = t->robot_->request(
        pr::Hello{pr::kProtocolVersion, {}, {}, described ? description : "", std::nullopt},
        milliseconds(500));
    if (!r && described && refused_described_hello(r.error())) {
      described = false;
      continue;
    }
    if (r) {
      const auto* hi = std::get_if<pr::PeerHello>(&r->last());
      if (hi == nullptr || hi->version != pr::kProtocolVersion) {
        return hub_error("physical robot: unexpected hello reply (protocol version mismatch?)");
      }
      if (Status s = check_description(
              *hi, fmt::format("the physical robot's firmware on {}", t->robot_if_->where()),
              description, o,
              "build and flash the firmware for this description (cmake "
              "-DSCARATWIN_ROBOT_DESCRIPTION=FILE), or start the hub with the firmware's --config");
          !s) {
        return s.error();
      }
      if (!described || !hi->description.empty() || ++undescribed_replies >= 2) break;
      continue;
    }
    if (std::chrono::steady_clock::now() > deadline) {
      return hub_error(fmt::format("physical robot on {} did not answer hello within {} s: {}",
                                   t->robot_if_->where(), o.hello_timeout_s, r.error().message));
    }
  }
  auto hi = t->sim_->request(sim_hello(o, description), ms(o.hello_timeout_s));
  if (!hi && refused_described_hello(hi.error())) {
    hi = t->sim_->request(sim_hello(o, ""), ms(o.hello_timeout_s));
  }
  if (hi) {
    const auto* peer = std::get_if<pr::PeerHello>(&hi->last());
    if (peer != nullptr) {
      if (Status s = check_description(
              *peer, fmt::format("the simulator at {}:{}", o.sim_host, o.sim_port), description, o,
              "start both with the same --config");
          !s) {
        return s.error();
      }
    }
  }
  if (!hi) {
    if (hi.error().code == protocol_error_code(pr::kErrNoRobot)) return hub_error(no_sim_robot(o));
    if (hi.error().code == protocol_error_code(pr::kErrAccess)) {
      return hub_error(fmt::format("simulator at {}:{} refused the hub: {}", o.sim_host, o.sim_port,
                                   access_refusal(hi.error().message, o)));
    }
    return hub_error(fmt::format("simulator hello: {}", hi.error().message));
  }
  // the simulator hosts the robot this hub drives (protocol v2: its index names it), asked
  // before the robot is told anything more than hello
  if (o.sim_robot != 0) {
    auto qs = t->sim_->request(pr::QueryState{o.sim_robot}, milliseconds(2000));
    if (!qs && qs.error().code == protocol_error_code(pr::kErrNoRobot)) {
      return hub_error(no_sim_robot(o));
    }
    if (!qs) return hub_error(fmt::format("simulator state: {}", qs.error().message));
  }
  // an un-homed robot's joints are its counts since power-up, not where it is (d1 reads 0 mm,
  // below its soft limit): the simulator takes them for no limit warning until homing ends
  // (home() restores the phase). Said before the robot's reports begin, and taken back at once
  // for a robot already homed.
  (void)t->set_twin_phase(pr::TwinPhase::kHoming);
  if (auto qs = t->robot_->request(pr::QueryState{}, milliseconds(1000)); qs) {
    const auto* st = std::get_if<pr::DeviceState>(&qs->last());
    if (st != nullptr && (st->flags & pr::state_flags::kHomed) != 0) {
      t->robot_homed_ = true;
      (void)t->set_twin_phase(t->twin_phase_.load());
    }
  }
  auto sr = t->robot_->request(pr::SetReportRate{o.report_rate_hz}, milliseconds(1000));
  if (!sr) return hub_error(fmt::format("set report rate: {}", sr.error().message));
  if (o.report_rate_hz > 0 && o.robot_silence_s > 0.0) {
    std::lock_guard<std::mutex> lock(t->mu_);
    t->silence_limit_s_ = std::max(o.robot_silence_s, 10.0 / o.report_rate_hz);
    t->last_robot_rx_us_ = tr::steady_now_us();
  }
  t->watchdog_ = std::thread([raw] { raw->watch_robot_link(); });
  {
    std::lock_guard<std::mutex> lock(t->mu_);
    t->connected_ = true;
  }
  return t;
}

// --- runs -----------------------------------------------------------------------------------

Result<std::int64_t> Hub::begin_run(const std::string& kind, const std::string& label,
                                    std::int64_t parent, std::int64_t ref) {
  std::lock_guard<std::mutex> lock(mu_);
  run_start_us_ = tr::steady_now_us();
  if (db_ == nullptr) return ++run_;
  auto r = db_->begin_run(kind, label, parent, ref);
  if (!r) return r.error();
  run_ = *r;
  return run_;
}

Status Hub::end_run(bool ok) {
  std::lock_guard<std::mutex> lock(mu_);
  if (db_ == nullptr || run_ == 0) return Ok{};
  const double dur = static_cast<double>(tr::steady_now_us() - run_start_us_) / 1e6;
  // nothing after its end goes into it: the reports until the next run are no run's
  return db_->end_run(std::exchange(run_, 0), ok ? "ok" : "failed", dur);
}

std::int64_t Hub::current_run() const {
  std::lock_guard<std::mutex> lock(mu_);
  return run_;
}

double Hub::run_time_s() const {
  std::lock_guard<std::mutex> lock(mu_);
  return static_cast<double>(tr::steady_now_us() - run_start_us_) / 1e6;
}

void Hub::record_event(const std::string& kind, const std::string& detail) {
  std::lock_guard<std::mutex> lock(mu_);
  if (db_ != nullptr && run_ != 0) {
    (void)db_->add_event(run_, static_cast<double>(tr::steady_now_us() - run_start_us_) / 1e6, kind,
                         detail);
  }
}

void Hub::record_metric(const std::string& name, double value, const std::string& unit) {
  std::lock_guard<std::mutex> lock(mu_);
  if (db_ != nullptr && run_ != 0) (void)db_->add_metric(run_, name, value, unit);
}

void Hub::add_sample(SampleSource source, double t_s, std::int64_t seq, const JointVector& q,
                     double grip_deg) {
  // mu_ held by the caller.
  if (db_ != nullptr && run_ != 0) (void)db_->add_sample(run_, source, {t_s, seq, q, grip_deg});
}

// --- mirror -----------------------------------------------------------------------------------

void Hub::set_mirror(bool on) {
  bool started = false;
  {
    std::lock_guard<std::mutex> lock(mu_);
    started = on && !mirror_;
    mirror_ = on;
  }
  // mirroring (again): the simulator in mirror mode, and a new stream of frames for it (the
  // reports the hub did not forward meanwhile were not lost, docs/protocol.md section 7)
  if (started) (void)sim_->post(pr::SetMode{pr::SimMode::kMirror, options_.sim_robot});
}

void Hub::on_sim_link(tr::LinkState state) {
  if (state == tr::LinkState::kConnected) {
    // a new connection: the hello again (the simulator admits a client on it, with the token
    // when it asks for one). The simulator counts as back once it answers: a hung one accepts
    // connections in its kernel and never answers (the heartbeat drops those again).
    const std::string description = description_hash(model_);
    (void)sim_->post(
        sim_hello(options_, description), [this, description](Result<tr::SimChannel::Reply>&& r) {
          const pr::PeerHello* peer = r ? std::get_if<pr::PeerHello>(&r->last()) : nullptr;
          Status same = peer != nullptr
                            ? check_description(*peer, "the simulator", description, options_,
                                                "start both with the same --config")
                            : Status{Ok{}};
          if (!same) {
            // a simulator restarted with another description: not back (nothing is sent to it)
            std::fprintf(stderr, "scaratwin: %s\n", same.error().message.c_str());
          } else if (r || refused_described_hello(r.error())) {
            on_sim_answered();
          } else if (r.error().code == protocol_error_code(pr::kErrAccess)) {
            std::fprintf(stderr, "scaratwin: the simulator refused the hub: %s\n",
                         access_refusal(r.error().message, options_).c_str());
          }
        });
    return;
  }
  // a hung simulator's connection was ended by the heartbeat: say so
  const std::string dropped = sim_->last_drop_reason();
  const std::string what = dropped.empty() ? std::string("the simulator link was lost")
                                           : "the simulator stopped answering (" + dropped + ")";
  bool stop_robot = false;
  {
    std::lock_guard<std::mutex> lock(mu_);
    if (!sim_up_) return;  // a connection that never answered its hello went again
    sim_up_ = false;
    // a hub still connecting (refused, say) fails in connect() saying why: no lost link
    if (!connected_) return;
    ++mirror_counters_.sim_link_losses;
    if (in_motion_ && motion_abort_.empty()) {
      motion_abort_ = fmt::format(
          "{} (the virtual robot no longer follows)",
          dropped.empty() ? "the simulator link was lost" : "the simulator stopped answering");
      abort_mark_ = event_count_;  // the stop's confirmation (EV 6) comes after this
      abort_stop_wait_s_ = 0.0;    // the reply timeout
      stop_robot = true;
    }
    cv_.notify_all();
  }
  // the stop goes out at once from here; the statement waiting for the trajectory wakes,
  // confirms it and fails saying why
  if (stop_robot) (void)robot_->send_realtime(pr::Realtime::kStop);
  std::fprintf(stderr, "scaratwin: %s%s; reconnecting\n", what.c_str(),
               stop_robot ? " during a move: stopping the robot" : "");
  record_event("link", stop_robot ? what + " during a move: robot stopped" : what);
}

void Hub::on_sim_answered() {
  bool mirror = false;
  {
    std::lock_guard<std::mutex> lock(mu_);
    if (sim_up_) return;
    sim_up_ = true;
    mirror = mirror_;
    sim_grip_closed_ = false;  // a restarted simulator has its gripper open
  }
  // the mirror mode for a new stream of frames
  if (mirror) (void)sim_->post(pr::SetMode{pr::SimMode::kMirror, options_.sim_robot});
  std::fprintf(stderr, "scaratwin: the simulator link is back\n");
  record_event("link", "simulator link back");
}

MirrorCounters Hub::mirror_counters() const {
  std::lock_guard<std::mutex> lock(mu_);
  MirrorCounters c = mirror_counters_;
  c.lost = robot_ ? robot_->lost_packets() : 0;
  return c;
}

void Hub::watch_robot_link() {
  std::unique_lock<std::mutex> lock(mu_);
  std::int64_t last_pass_us = tr::steady_now_us();
  while (!watchdog_quit_) {
    cv_.wait_for(lock, milliseconds(10));
    if (watchdog_quit_ || silence_limit_s_ <= 0.0) continue;
    const std::int64_t now_us = tr::steady_now_us();
    // a pass that comes 100 ms late means this process was not running (a busy host): the
    // reports that came meanwhile wait unread, so nothing is judged until the next pass
    const bool late = now_us - last_pass_us > kLatePassUs;
    last_pass_us = now_us;
    if (late) continue;
    const std::int64_t quiet_us = now_us - last_robot_rx_us_;
    std::string say;
    bool stop_robot = false;
    if (!robot_silent_ && static_cast<double>(quiet_us) >= silence_limit_s_ * 1e6) {
      // said at once; what it was (a cut, or the robot itself stalled with its clock, as an
      // emulator on a busy host does) shows in the robot's clock when its reports come back
      robot_silent_ = true;
      silence_said_ = in_motion_;  // on stderr during a move; otherwise the event log only
      say = fmt::format(
          "no state report from the robot for {} ms (the link cut, or the robot stalled)",
          quiet_us / 1000);
    } else if (robot_silent_ && in_motion_ && motion_abort_.empty() &&
               static_cast<double>(quiet_us) >=
                   std::max(options_.reply_timeout_s, kRobotSilenceAbortMinS) * 1e6) {
      // longer than the robot's queue lasts: the move is over whatever it was
      say = fmt::format("the robot link is silent for {} ms (cut or unplugged)", quiet_us / 1000);
      motion_abort_ = say;
      abort_mark_ = event_count_;  // the stop's confirmation (EV 6) comes after this
      abort_stop_wait_s_ = 0.5;    // it can only come once the link is back
      stop_robot = true;
      stop_owed_ = true;
    }
    if (say.empty()) continue;
    const bool print = stop_robot || silence_said_;
    cv_.notify_all();
    lock.unlock();
    if (stop_robot) {
      // sent into the silence (it gets through if only the robot's side went quiet), again
      // with the first report after it; the requests waiting for replies fail now, so the
      // statement sending the trajectory ends at once
      (void)robot_->send_realtime(pr::Realtime::kStop);
      robot_->fail_pending("the robot link is silent");
    }
    if (print) {
      std::fprintf(stderr, "scaratwin: %s%s\n", say.c_str(),
                   stop_robot ? " during a move: stopping the robot" : "");
    }
    record_event("link", stop_robot ? say + " during a move: robot stopped" : say);
    lock.lock();
  }
}

void Hub::on_robot_packet(pr::SerialFromDevice&& msg, const tr::RxPacket& rx) {
  {
    const auto* st = std::get_if<pr::DeviceState>(&msg);
    std::string say;
    bool stop_robot = false;
    bool print = false;
    {
      std::lock_guard<std::mutex> lock(mu_);
      const std::int64_t gap_ms = (rx.steady_us - last_robot_rx_us_) / 1000;
      last_robot_rx_us_ = std::max(last_robot_rx_us_, rx.steady_us);
      if (st != nullptr) {
        // The robot's clock against the hub's tells a cut from a stall. Reports are one
        // period apart in the robot's clock (10 ms at 100 Hz). A cut: the robot's clock ran on
        // by the silence limit or more between two reports received in a row, and the hub's
        // clock saw as long a gap (at least half of it) between receiving them: the link lost
        // the reports between. A robot that stalled (an emulator on a busy host) stops its
        // clock too; a hub that stalled reads the reports it missed, each one period on, and
        // when it fell so far behind that its input overflowed, the reports it lost leave a
        // jump in the robot's clock between two reports it read in one go (no gap in its own
        // clock): not the link's doing. The first line after a cut may be two reports spliced
        // where the bytes were lost (the wire has no checksum): it decodes with the clock of
        // the report before the cut, one period on, and looks like a stall; so the report after
        // the first one after a silence is measured from the one before the silence, and a
        // stall is said only once that second report confirms it.
        const bool from_anchor = stall_pending_;
        const std::uint32_t x_t_us = from_anchor ? anchor_t_us_ : last_robot_t_us_;
        const std::int64_t x_rx_us = from_anchor ? anchor_rx_us_ : last_report_rx_us_;
        const std::int64_t robot_ms = static_cast<std::int32_t>(st->t_us - x_t_us) / 1000;
        const std::int64_t wall_ms = (rx.steady_us - x_rx_us) / 1000;
        const auto limit_ms = static_cast<std::int64_t>(std::round(silence_limit_s_ * 1e3));
        const bool jumped = robot_clock_known_ && silence_limit_s_ > 0.0 && robot_ms >= limit_ms;
        if (jumped && 2 * wall_ms >= limit_ms) {
          const bool after_silence = robot_silent_ || stall_pending_;
          robot_silent_ = false;
          stall_pending_ = false;
          const std::string cut = fmt::format(
              "the robot link was cut for {} ms of the robot's time (cut or unplugged)", robot_ms);
          if (in_motion_ && motion_abort_.empty()) {
            motion_abort_ = cut;
            abort_mark_ = event_count_;
            abort_stop_wait_s_ = 0.0;  // the reply timeout
            stop_owed_ = true;
          }
          stop_robot = stop_owed_;
          stop_owed_ = false;
          say =
              fmt::format("{}: {}{}",
                          after_silence ? fmt::format("the robot link is back after {} ms", wall_ms)
                                        : std::string("the robot's state reports skipped ahead"),
                          cut, stop_robot ? ": stopping the robot" : "");
          print = true;
          cv_.notify_all();
        } else if (jumped) {
          // the event log only: the move goes on
          say = fmt::format(
              "{} ms of the robot's state reports lost between two read {} ms apart: this host "
              "read them late and its input overflowed (not a cut)",
              robot_ms, wall_ms);
        } else if (robot_silent_) {
          // the first report after a silence, the clock one period on: a stall, unless the
          // next report jumps from the one before the silence (this one spliced)
          robot_silent_ = false;
          stall_pending_ = true;
          stall_gap_ms_ = gap_ms;
          stall_robot_ms_ = robot_ms;
          anchor_t_us_ = last_robot_t_us_;
          anchor_rx_us_ = last_report_rx_us_;
          cv_.notify_all();
        } else if (stall_pending_) {
          stall_pending_ = false;
          say = fmt::format(
              "the robot's reports are back after {} ms; its own clock stood still as long "
              "({} ms): the robot stalled, not the link",
              stall_gap_ms_, stall_robot_ms_);
          print = silence_said_;
        }
        if (jumped) stall_pending_ = false;
        last_report_rx_us_ = rx.steady_us;
        last_robot_t_us_ = st->t_us;
        robot_clock_known_ = true;
      }
    }
    if (!say.empty()) {
      if (stop_robot) {
        (void)robot_->send_realtime(pr::Realtime::kStop);
        robot_->fail_pending("the robot link was cut");
      }
      if (print) std::fprintf(stderr, "scaratwin: %s\n", say.c_str());
      record_event("link", say);
    }
  }
  // one handler per packet the robot may send unasked and no generic one: a new message type
  // of the link does not compile here until the hub says what it does with it
  std::visit(Overloaded{
                 [&](const pr::DeviceState& st) { on_device_state(st, rx); },
                 [&](const pr::DeviceEvent& ev) {
                   std::lock_guard<std::mutex> lock(mu_);
                   events_.emplace_back(++event_count_, ev);
                   if (events_.size() > 256) events_.pop_front();
                   if (db_ != nullptr && run_ != 0) {
                     (void)db_->add_event(
                         run_, static_cast<double>(rx.steady_us - run_start_us_) / 1e6, "robot",
                         fmt::format("EV {} {}", static_cast<int>(ev.event), ev.value.value_or(0)));
                   }
                   cv_.notify_all();
                 },
                 [&](const pr::PeerHello&) {
                   {
                     std::lock_guard<std::mutex> lock(mu_);
                     robot_clock_known_ = false;  // its clock started again
                     stall_pending_ = false;
                     sample_clock_.reset();
                     robot_homed_ = false;  // it powered up anew
                   }
                   record_event("robot", "unsolicited hello: the robot reset");
                 },
                 // a reply with no request waiting for it (the channel matched every other one)
                 [&](const pr::Ack& ak) { record_event("robot", "unsolicited AK " + ak.code); },
                 [&](const pr::ErrorReply& er) {
                   record_event(
                       "robot",
                       fmt::format("unsolicited ER {} ({})", er.code,
                                   pr::core::error_name(static_cast<std::uint8_t>(er.code))));
                 },
             },
             msg);
}

void Hub::on_device_state(const pr::DeviceState& st, const tr::RxPacket& rx) {
  PhysicalState ps;
  ps.raw = st;
  ps.grip_deg = rad_to_deg(st.grip_rad);
  ps.rx_steady_us = rx.steady_us;
  ps.valid = true;
  bool mirror;
  {
    std::lock_guard<std::mutex> lock(mu_);
    ps.q = motors_to_joints(model_,
                            {static_cast<double>(st.steps[0]), static_cast<double>(st.steps[1]),
                             static_cast<double>(st.steps[2])},
                            rad_to_deg(st.wrist_rad));
    // a calibrated backlash: a joint stays put while its motor moves within the dead band,
    // and trails it by half the band once the motor drags it (the side it then rests on is
    // report_dir_); after homing each joint trails its motor away from the switch
    const auto& band = model_.calibration.backlash;
    if (state_count_ == 0 || play_reset_) {
      const JointVector shift = backlash_shift(model_, report_dir_);
      for (int j = 0; j < kNumSteppers; ++j) report_joint_[j] = ps.q[j] + shift[j];
      play_reset_ = false;
    }
    for (int j = 0; j < kNumSteppers; ++j) {
      const double lo = ps.q[j] - 0.5 * band[j], hi = ps.q[j] + 0.5 * band[j];
      const double e = std::clamp(report_joint_[j], lo, hi);
      if (band[j] > 0.0 && e <= lo) report_dir_[j] = 1;
      if (band[j] > 0.0 && e >= hi) report_dir_[j] = -1;
      if (band[j] == 0.0 && std::abs(ps.q[j] - report_joint_[j]) > 1e-9) {
        report_dir_[j] = ps.q[j] > report_joint_[j] ? 1 : -1;
      }
      report_joint_[j] = e;
      ps.q[j] = e;
    }
    physical_ = ps;
    ++state_count_;
    add_sample(SampleSource::kPhysical, static_cast<double>(rx.steady_us - run_start_us_) / 1e6,
               st.seq, ps.q, ps.grip_deg);
    // desync alarm against the trajectory being run: off the planned path, not off the
    // planned clock. The report's progress along the plan is followed from report to report,
    // so a queue underrun, a late start or a clock that runs at another rate (an emulator
    // slowed by a busy host) shifts the timing without moving the tool off the path. The
    // reports carry the firmware's step counters: a motor that stalls and loses steps shows
    // only where the true position is measured (the emulator's side channel).
    if (tracker_) {
      const double dev = tracker_->follow(model_, ps.q).tool_distance_m;
      if (desync_.check(dev)) {
        ++desync_alarms_;
        if (db_ != nullptr && run_ != 0) {
          (void)db_->add_event(run_, static_cast<double>(rx.steady_us - run_start_us_) / 1e6,
                               "desync", fmt::format("tool {:.1f} mm off the plan", m_to_mm(dev)));
        }
      }
    }
    cv_.notify_all();
    mirror = mirror_;
  }
  if (mirror) forward_to_sim(ps);
}

void Hub::forward_to_sim(const PhysicalState& ps) {
  pr::JointData jd;
  jd.seq = ps.raw.seq;
  jd.q = ps.q;
  jd.robot = options_.sim_robot;
  const std::int64_t rx_us = ps.rx_steady_us;
  const std::uint32_t device_t = ps.raw.t_us;
  const JointVector q = ps.q;
  const double grip = ps.grip_deg;
  std::int64_t sample_us = rx_us;
  {
    std::lock_guard<std::mutex> lock(mu_);
    ++mirror_counters_.frames;
    // the sample time in the hub's clock (docs/protocol.md, JD): the simulator's latency
    // figures then start where the report's do, at the robot's sample
    sample_us = sample_clock_.sample_time_us(device_t, rx_us);
    jd.t_us = static_cast<std::uint32_t>(sample_us);
  }
  const auto not_applied = [this] {
    std::lock_guard<std::mutex> lock(mu_);
    ++mirror_counters_.not_applied;
  };
  const Status posted = sim_->post(
      jd,
      [this, rx_us, sample_us, device_t, q, grip, seq = jd.seq,
       not_applied](Result<tr::SimChannel::Reply>&& r) {
        const auto* ja = r ? std::get_if<pr::JointApplied>(&r->last()) : nullptr;
        if (ja == nullptr) {
          not_applied();
          return;
        }
        // the apply time is the simulator's steady clock modulo 2^32: unwrap it near rx_us.
        const auto delta =
            static_cast<std::int32_t>(ja->t_apply_us - static_cast<std::uint32_t>(rx_us));
        const std::int64_t apply_us = rx_us + delta;
        std::lock_guard<std::mutex> lock(mu_);
        // from the robot's sample, as the report counts it
        const double lat_ms = static_cast<double>(apply_us - sample_us) / 1000.0;
        ++mirror_counters_.applied;
        latency_sum_ms_ += lat_ms;
        mirror_counters_.last_latency_ms = lat_ms;
        mirror_counters_.mean_latency_ms =
            latency_sum_ms_ / static_cast<double>(mirror_counters_.applied);
        if (db_ != nullptr && run_ != 0) {
          (void)db_->add_latency(run_, {seq, device_t, rx_us, apply_us});
          add_sample(SampleSource::kVirtual, static_cast<double>(apply_us - run_start_us_) / 1e6,
                     seq, q, grip);
        }
      },
      milliseconds(2000));
  if (!posted) not_applied();
  // the simulator's gripper follows the robot's gripper servo.
  const double mid = 0.5 * (model_.motors.gripper_open_deg + model_.motors.gripper_closed_deg);
  const bool closed =
      (model_.motors.gripper_closed_deg > model_.motors.gripper_open_deg) ? grip > mid : grip < mid;
  bool changed = false;
  {
    std::lock_guard<std::mutex> lock(mu_);
    if (closed != sim_grip_closed_) {
      sim_grip_closed_ = closed;
      changed = true;
    }
  }
  if (changed) {
    pr::Grasp grasp{closed};
    grasp.robot = options_.sim_robot;
    (void)sim_->post(grasp);
  }
}

// --- physical robot ---------------------------------------------------------------------------

PhysicalState Hub::physical() const {
  std::lock_guard<std::mutex> lock(mu_);
  return physical_;
}

Result<PhysicalState> Hub::fresh_physical(double timeout_s) {
  std::unique_lock<std::mutex> lock(mu_);
  const std::uint64_t n = state_count_;
  if (!cv_.wait_for(lock, ms(timeout_s), [&] { return state_count_ > n || interrupted_; })) {
    return hub_error(fmt::format("no state report from the robot within {} s", timeout_s));
  }
  if (interrupted_) return hub_error(kInterrupted);
  return physical_;
}

Status Hub::check(const char* what, Result<tr::RobotChannel::Reply> r) {
  if (!r) return hub_error(fmt::format("robot {}: {}", what, r.error().message));
  return Ok{};
}

Result<pr::DeviceEvent> Hub::wait_event(pr::DeviceEventCode code, double timeout_s,
                                        std::uint64_t after) {
  return wait_event({code}, timeout_s, after);
}

Result<pr::DeviceEvent> Hub::wait_event(std::initializer_list<pr::DeviceEventCode> codes,
                                        double timeout_s, std::uint64_t after) {
  std::unique_lock<std::mutex> lock(mu_);
  std::optional<pr::DeviceEvent> found;
  const auto pred = [&] {
    if (motion_aborted()) return true;
    for (const auto& [n, ev] : events_) {
      if (n > after && std::find(codes.begin(), codes.end(), ev.event) != codes.end()) {
        found = ev;
        return true;
      }
    }
    return false;
  };
  if (!cv_.wait_for(lock, ms(timeout_s), pred)) {
    return hub_error(fmt::format("robot: event {} did not come within {:.0f} s",
                                 static_cast<int>(*codes.begin()), timeout_s));
  }
  if (!found) return hub_error(interrupted_ ? std::string(kInterrupted) : motion_abort_);
  return *found;
}

Status Hub::wait_flags(const std::function<bool(std::uint32_t)>& done, double timeout_s) {
  std::unique_lock<std::mutex> lock(mu_);
  const std::uint64_t n = state_count_;
  const auto pred = [&] { return interrupted_ || (state_count_ > n && done(physical_.raw.flags)); };
  if (!cv_.wait_for(lock, ms(timeout_s), pred)) {
    return hub_error(fmt::format("the robot is still moving after {:.0f} s", timeout_s));
  }
  if (interrupted_) return hub_error(kInterrupted);
  return Ok{};
}

void Hub::set_model(const RobotModel& model) {
  MotionDirections dir;
  {
    std::lock_guard<std::mutex> lock(mu_);
    model_ = model;
    // a new dead band: each joint taken to rest on the side it last moved to (its motor
    // leading it by half the band), and the trajectories' lead made to agree
    play_reset_ = true;
    dir = report_dir_;
  }
  if (statements_) statements_->set_directions(dir);
}

MotionDirections Hub::directions() const {
  std::lock_guard<std::mutex> lock(mu_);
  return report_dir_;
}

Status Hub::wait_idle(double timeout_s) {
  return wait_flags(
      [](std::uint32_t f) {
        return (f & (pr::state_flags::kMoving | pr::state_flags::kTrajectory)) == 0;
      },
      timeout_s);
}

Status Hub::wait_motors_at_rest(double timeout_s) {
  // a hold at rest reports "moving" (its segment is not finished)
  return wait_flags(
      [](std::uint32_t f) {
        return (f & pr::state_flags::kMoving) == 0 || (f & pr::state_flags::kHold) != 0;
      },
      timeout_s);
}

Status Hub::recover() {
  auto now = fresh_physical(2.0);
  if (!now) return now.error();
  namespace f = pr::state_flags;
  const std::uint32_t flags = now->raw.flags;
  const bool held = (flags & f::kHold) != 0;
  const bool abandoned = (flags & f::kTrajectory) != 0 && (flags & f::kMoving) == 0;
  if (!held && !abandoned && (flags & f::kHalted) == 0) return Ok{};
  if (held || abandoned) {
    if (Status s = stop(); !s) return s;
  }
  std::uint64_t mark;
  {
    std::lock_guard<std::mutex> lock(mu_);
    mark = event_count_;
  }
  if (Status s = robot_->send_realtime(pr::Realtime::kResume); !s) return s;
  auto ev = wait_event(pr::DeviceEventCode::kResumed, options_.reply_timeout_s, mark);
  if (!ev) return hub_error(fmt::format("robot: clearing the halt: {}", ev.error().message));
  record_event("robot", held        ? "a hold left by an earlier motion was stopped and cleared"
                        : abandoned ? "a trajectory left by an earlier host was stopped"
                                    : "the halt after a stop was cleared");
  return Ok{};
}

Status Hub::home(double timeout_s) {
  std::uint64_t mark;
  {
    std::lock_guard<std::mutex> lock(mu_);
    mark = event_count_;
  }
  // homing starts from rest: a move that a host which gave up left running out its queue
  // ends first (HM then drops what it left)
  if (Status s = wait_motors_at_rest(60.0); !s) return s;
  // the robot passes its soft limits on the way to its endstops: the simulator notes no
  // limit warning until homing ends (best effort: a missing simulator does not stop homing)
  robot_homed_ = false;  // until EV 1 says otherwise
  (void)set_twin_phase(pr::TwinPhase::kHoming);
  struct RestorePhase {
    Hub* hub;
    ~RestorePhase() { (void)hub->set_twin_phase(hub->twin_phase_.load()); }
  } restore{this};
  if (Status s = check("home", robot_->request(pr::Home{}, milliseconds(1000))); !s) return s;
  auto ev = wait_event({pr::DeviceEventCode::kHomed, pr::DeviceEventCode::kHomingFailed}, timeout_s,
                       mark);
  if (!ev) return ev.error();
  if (ev->event == pr::DeviceEventCode::kHomingFailed) {
    static constexpr const char* kAxis[] = {"Z", "J2", "J3"};
    const int axis = ev->value.value_or(-1);
    return hub_error(fmt::format("homing failed: the {} endstop was not found (switch or cable)",
                                 axis >= 0 && axis < 3 ? kAxis[axis] : "?"));
  }
  robot_homed_ = true;  // (before the phase is restored)
  // homing leaves each joint moving away from its switch
  statements_->set_directions(homed_directions(model_));
  // the offsets come just before EV 1 when the robot was homed before
  std::unique_lock<std::mutex> lock(mu_);
  report_dir_ = homed_directions(model_);
  play_reset_ = true;
  HomingCheck c;
  for (const auto& [n, e] : events_) {
    const int k = static_cast<int>(e.event) - static_cast<int>(pr::DeviceEventCode::kHomingOffsetZ);
    if (n > mark && k >= 0 && k < 3) {
      c.measured = true;
      c.offset_steps[static_cast<std::size_t>(k)] = e.value.value_or(0);
    }
  }
  if (c.measured) {
    // at the home pose, where homing ends
    c.tool_m = lost_steps_tool_offset_m(
        model_,
        {static_cast<double>(physical_.raw.steps[0]), static_cast<double>(physical_.raw.steps[1]),
         static_cast<double>(physical_.raw.steps[2])},
        c.offset_steps, rad_to_deg(physical_.raw.wrist_rad));
    const std::string what = fmt::format(
        "homing again: counts off the switches by Z {}, J2 {}, J3 {} steps (tool "
        "{:.2f} mm)",
        c.offset_steps[0], c.offset_steps[1], c.offset_steps[2], m_to_mm(c.tool_m));
    const double t_s = static_cast<double>(tr::steady_now_us() - run_start_us_) / 1e6;
    if (db_ != nullptr && run_ != 0) (void)db_->add_event(run_, t_s, "homing", what);
    if (c.tool_m > options_.desync_threshold_m) {
      ++desync_alarms_;
      if (db_ != nullptr && run_ != 0) {
        (void)db_->add_event(run_, t_s, "desync", "lost steps: " + what);
      }
    }
  }
  last_homing_ = c;
  lock.unlock();
  // still in the homing phase (the simulator notes no limit warning for where homing ended)
  return settle_at_home();
}

// Homing ends where the firmware's counts put the description's home pose. Through a
// calibrated joint map that is a little elsewhere, even beyond a soft limit (home lies on the
// limits of d1 and q4): a calibrated switch 1 mm low reads d1 121 mm for a 120 mm limit, and
// every plan from there would be refused. A short move brings the robot to home, kept one motor
// quantum inside each limit and within the wrist servo's reach. The firmware's homing leaves the
// wrist where it was, so an uncalibrated robot moves only its wrist, and only when it is away.
Status Hub::settle_at_home() {
  auto now = fresh_physical(2.0);
  if (!now) return now.error();
  const MotorModel& m = model_.motors;
  const double wrist_us = m.wrist.pulse_max_us - m.wrist.pulse_min_us;
  // the smallest step each joint's motor makes: one step, or one microsecond of servo pulse
  const JointVector quantum{
      1.0 / m.z.steps_per_unit, 1.0 / m.j2.steps_per_unit, 1.0 / m.j3.steps_per_unit,
      deg_to_rad((m.wrist.max_deg - m.wrist.min_deg) / (wrist_us > 0.0 ? wrist_us : 1.0))};
  // the wrist servo's range as the calibrated joint map reads it: a horn found 2.4 deg off
  // makes q4 0 unreachable (the servo stops at its end), so the move ends where it can
  const double wrist_lo =
      firmware_to_joints(model_, {0.0, 0.0, 0.0, deg_to_rad(m.wrist.min_deg)})[3];
  const double wrist_hi =
      firmware_to_joints(model_, {0.0, 0.0, 0.0, deg_to_rad(m.wrist.max_deg)})[3];
  JointVector target = model_.home;
  bool away = false;
  for (int j = 0; j < kNumJoints; ++j) {
    const JointLimit& l = model_.limits[j];
    double lo = l.min + quantum[j], hi = l.max - quantum[j];
    if (j == 3) {
      lo = std::max(lo, std::min(wrist_lo, wrist_hi) + quantum[j]);
      hi = std::min(hi, std::max(wrist_lo, wrist_hi) - quantum[j]);
    }
    target[j] = std::clamp(target[j], lo, hi);
    const double q = now->q[j];
    if (std::abs(q - target[j]) > quantum[j] || q < l.min || q > l.max) away = true;
  }
  if (!away) return Ok{};
  const double duration_s = std::max(0.3, 1.2 * quintic_min_duration(model_, now->q, target));
  const JointTrajectory move = quintic(now->q, target, duration_s, 30);
  auto run = run_trajectory(move);
  if (!run) {
    return hub_error(
        fmt::format("homed, but the move to the home pose failed: {}", run.error().message));
  }
  record_event("homing", fmt::format("moved {:.2f} mm, {:.2f} deg to the home pose",
                                     m_to_mm(std::abs(target[0] - now->q[0])),
                                     rad_to_deg(std::abs(target[3] - now->q[3]))));
  return Ok{};
}

HomingCheck Hub::last_homing() const {
  std::lock_guard<std::mutex> lock(mu_);
  return last_homing_;
}

Status Hub::set_gripper(bool closed) {
  auto r = closed ? statements_->grip(tr::Robots::kPhysical)
                  : statements_->release(tr::Robots::kPhysical);
  if (!r) return hub_error(fmt::format("robot gripper: {}", r.error().message));
  return Ok{};
}

Status Hub::jog(pr::Axis axis, double delta) {
  return check("jog", robot_->request(pr::Jog{axis, delta}, milliseconds(1000)));
}

Status Hub::set_setting(int key, int value) {
  return check("CF", robot_->request(pr::Config{key, value}, milliseconds(1000)));
}

Status Hub::stop(double timeout_s) {
  std::uint64_t mark;
  {
    std::lock_guard<std::mutex> lock(mu_);
    mark = event_count_;
  }
  if (Status s = robot_->send_realtime(pr::Realtime::kStop); !s) {
    return hub_error(fmt::format("robot stop: {}", s.error().message));
  }
  return wait_stopped(mark, timeout_s);
}

Status Hub::wait_stopped(std::uint64_t mark, double timeout_s) {
  // the confirmation is waited for even when interrupted: interrupt() calls this. Its
  // deadline is the link's reply timeout: a robot that answers no request in that time is
  // gone, one that does is stopping (an emulated one on a busy computer may take longer
  // than its real deceleration)
  if (timeout_s <= 0) timeout_s = options_.reply_timeout_s;
  std::unique_lock<std::mutex> lock(mu_);
  const auto stopped = [&] {
    for (const auto& [n, ev] : events_) {
      if (n > mark && ev.event == pr::DeviceEventCode::kStopped) return true;
    }
    return false;
  };
  if (!cv_.wait_for(lock, ms(timeout_s), stopped)) {
    return hub_error(fmt::format(
        "robot stop: not confirmed within {:.1f} s (link cut or robot gone); a robot that "
        "hears nothing from its host stops by itself when its queued points run out",
        timeout_s));
  }
  return Ok{};
}

void Hub::interrupt() {
  interrupted_ = true;
  {
    std::lock_guard<std::mutex> lock(mu_);
    cv_.notify_all();
  }
  const Status s = stop();
  record_event("interrupted", s ? "the robot stopped" : s.error().message);
}

Status Hub::sleep(double seconds) {
  std::unique_lock<std::mutex> lock(mu_);
  cv_.wait_for(lock, ms(seconds), [&] { return interrupted_.load(); });
  if (interrupted_) return hub_error(kInterrupted);
  return Ok{};
}

double Hub::off_plan_worst_m() const {
  std::lock_guard<std::mutex> lock(mu_);
  return desync_.worst_deviation_m();
}

Result<int> Hub::run_trajectory(const JointTrajectory& traj, double timeout_s) {
  if (traj.samples.size() < 2) return 0;
  // a trajectory may start beyond a limit (a calibrated robot homed just outside one) as long
  // as it comes back: the limits are widened to its first sample, no further
  RobotModel bounds = model_;
  for (int j = 0; j < kNumJoints; ++j) {
    JointLimit& l = bounds.limits[j];
    l.min = std::min(l.min, traj.samples.front().q[j]);
    l.max = std::max(l.max, traj.samples.front().q[j]);
  }
  if (Status s = check_limits(bounds, traj); !s) {
    return hub_error(
        fmt::format("trajectory refused before anything moved: {}", s.error().message));
  }
  // a trajectory starts from rest: let a jog or the previous move finish (also one that a
  // host that gave up left running out its queue), clear what it left, start.
  if (Status s = wait_motors_at_rest(60.0); !s) return s.error();
  if (Status s = recover(); !s) return s.error();
  if (Status s = wait_idle(10.0); !s) return s.error();
  std::uint64_t mark;
  {
    std::lock_guard<std::mutex> lock(mu_);
    mark = event_count_;
    tracker_.emplace(traj, kDesyncWindowS);
    desync_ = DesyncMonitor(options_.desync_threshold_m, options_.desync_persist);
    in_motion_ = true;
    motion_abort_.clear();
  }
  const auto clear_tracker = [&] {
    std::lock_guard<std::mutex> lock(mu_);
    tracker_.reset();
    in_motion_ = false;
  };
  // why the trajectory was cut short by the hub itself (the simulator lost), or empty
  const auto abort_reason = [&] {
    std::lock_guard<std::mutex> lock(mu_);
    return motion_abort_;
  };
  // numberTran3: TB, then the points under the device's credit. The robot interpolates
  // between points, so points closer than min_point_dt_s are thinned out (keeping the ends
  // and every gripper event): fewer packets, more slack against a busy host.
  JointTrajectory sent;
  sent.events = traj.events;
  size_t next_event = 0;
  for (size_t k = 0; k < traj.samples.size(); ++k) {
    const JointSample& smp = traj.samples[k];
    bool keep = k == 0 || k + 1 == traj.samples.size() ||
                smp.t_s - sent.samples.back().t_s >= options_.min_point_dt_s - 1e-9;
    while (next_event < traj.events.size() && traj.events[next_event].t_s <= smp.t_s + 1e-9) {
      keep = true;
      ++next_event;
    }
    if (keep) {
      // the firmware takes a point at most 5 s after the previous one (docs/protocol.md, TP):
      // a longer stretch (a robot of a workcell waiting for another) gets points between, on
      // the line the robot interpolates anyway
      if (!sent.samples.empty()) {
        const JointSample prev = sent.samples.back();
        const int pieces = static_cast<int>(std::ceil((smp.t_s - prev.t_s) / kLongestPointS));
        for (int i = 1; i < pieces; ++i) {
          const double f = static_cast<double>(i) / pieces;
          JointSample mid = prev;
          mid.t_s = prev.t_s + f * (smp.t_s - prev.t_s);
          for (int j = 0; j < kNumJoints; ++j) mid.q[j] = prev.q[j] + f * (smp.q[j] - prev.q[j]);
          sent.samples.push_back(mid);
        }
      }
      sent.samples.push_back(smp);
    }
  }
  // whatever ends the trajectory early stops the robot first, so that it never keeps a
  // trajectory its host gave up on
  const auto give_up = [&](const std::string& what) -> Error {
    clear_tracker();
    std::optional<std::uint64_t> sent_at;  // a stop the link watcher already sent
    double stop_wait_s = 0.0;              // the reply timeout
    {
      std::lock_guard<std::mutex> lock(mu_);
      if (!motion_abort_.empty()) {
        sent_at = abort_mark_;
        stop_wait_s = abort_stop_wait_s_;
      }
    }
    const Status stopped = sent_at ? wait_stopped(*sent_at, stop_wait_s) : stop();
    return hub_error(fmt::format(
        "{}; {}", what, stopped ? std::string("the robot was stopped") : stopped.error().message));
  };
  if (!sim_link_up()) {
    clear_tracker();
    return hub_error("the simulator link is down (reconnecting): nothing moved");
  }
  const bool robot_silent = [&] {
    std::lock_guard<std::mutex> lock(mu_);
    return robot_silent_;
  }();
  if (robot_silent) {
    clear_tracker();
    return hub_error("the robot link is silent (no state report: cut or unplugged): nothing moved");
  }
  auto load = statements_->load_trajectory(sent);
  if (interrupted_) return give_up(kInterrupted);
  if (const std::string why = abort_reason(); !why.empty()) return give_up(why);
  if (!load) return give_up(fmt::format("robot trajectory load: {}", load.error().message));
  const double wait_s = timeout_s > 0 ? timeout_s : traj.duration_s() + 15.0;
  auto done = wait_event(pr::DeviceEventCode::kTrajectoryDone, wait_s, mark);
  if (!done) return give_up(done.error().message);
  clear_tracker();
  return load->points;
}

tr::LinkCounters Hub::serial_counters() const { return robot_if_->counters(); }
tr::LinkCounters Hub::sim_counters() const { return tcp_->counters(); }

}  // namespace scaratwin
