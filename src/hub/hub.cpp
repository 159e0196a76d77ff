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

// A robot link silent during a trajectory ends it whatever the silence was after the reply
// timeout (HubOptions::reply_timeout_s, the same rule as for a request), and never before
// this: the robot's queue (at most 63 points of 20 ms) has run out by then on a cut link. A
// shorter limit ended healthy moves of an emulated robot that a busy host did not run for
// 1.5 s (its clock stood still: a stalled robot moves no further than its host lets it).
constexpr double kRobotSilenceAbortMinS = 1.5;
// A watchdog pass this much later than due: the hub itself was not running.
constexpr std::int64_t kLatePassUs = 100000;

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

// What an ER,18 to the hub's hello means (docs/protocol.md section 6), from its detail field.
std::string access_refusal(const Error& refusal, const HubOptions& o) {
  if (refusal.detail == 1) {
    return o.sim_token.empty() ? "it needs its access token (--sim-token or SCARATWIN_TOKEN)"
                               : "wrong access token";
  }
  if (refusal.detail == 2) return "another client controls it (stop that hub first)";
  return refusal.message;
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
  // the simulator first: its channel's heartbeat starts with the connection, and a simulator
  // admits a client on its first line, so a heartbeat sent while a board spends its 1.5 s in
  // the bootloader would claim the whole simulator before the hello names the robot
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
                                   access_refusal(hi.error(), o)));
    }
    return hub_error(fmt::format("simulator hello: {}", hi.error().message));
  }
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
      const auto* board = std::get_if<pr::PeerHello>(&r->last());
      if (board == nullptr || board->version != pr::kProtocolVersion) {
        return hub_error("physical robot: unexpected hello reply (protocol version mismatch?)");
      }
      if (Status s = check_description(
              *board, fmt::format("the physical robot's firmware on {}", t->robot_if_->where()),
              description, o,
              "build and flash the firmware for this description (cmake "
              "-DSCARATWIN_ROBOT_DESCRIPTION=FILE), or start the hub with the firmware's --config");
          !s) {
        return s.error();
      }
      if (!described || !board->description.empty() || ++undescribed_replies >= 2) break;
      continue;
    }
    if (std::chrono::steady_clock::now() > deadline) {
      return hub_error(fmt::format("physical robot on {} did not answer hello within {} s: {}",
                                   t->robot_if_->where(), o.hello_timeout_s, r.error().message));
    }
    // a board in its bootloader took that hello as its own and will never answer it: a later
    // reply answers the next hello, not this one
    t->robot_->forget_abandoned();
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
            say(same.error().message);
          } else if (r || refused_described_hello(r.error())) {
            on_sim_answered();
          } else if (r.error().code == protocol_error_code(pr::kErrAccess)) {
            say("the simulator refused the hub: " + access_refusal(r.error(), options_));
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
  say(what + (stop_robot ? " during a move: stopping the robot" : "") + "; reconnecting");
  record_event("link", stop_robot ? what + " during a move: robot stopped" : what);
}

void Hub::say(const std::string& text) const {
  const std::string who =
      options_.log_name.empty() ? std::string() : fmt::format("robot '{}': ", options_.log_name);
  std::fprintf(stderr, "scaratwin: %s%s\n", who.c_str(), text.c_str());
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
  say("the simulator link is back");
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
    std::string news;
    bool stop_robot = false;
    if (!robot_silent_ && static_cast<double>(quiet_us) >= silence_limit_s_ * 1e6) {
      // said at once; what it was (a cut, or the robot itself stalled with its clock, as an
      // emulator on a busy host does) shows in the robot's clock when its reports come back
      robot_silent_ = true;
      silence_said_ = in_motion_;  // on stderr during a move; otherwise the event log only
      news = fmt::format(
          "no state report from the robot for {} ms (the link cut, or the robot stalled)",
          quiet_us / 1000);
    } else if (robot_silent_ && in_motion_ && motion_abort_.empty() &&
               static_cast<double>(quiet_us) >=
                   std::max(options_.reply_timeout_s, kRobotSilenceAbortMinS) * 1e6) {
      // longer than the robot's queue lasts: the move is over whatever it was
      news = fmt::format("the robot link is silent for {} ms (cut or unplugged)", quiet_us / 1000);
      motion_abort_ = news;
      abort_mark_ = event_count_;  // the stop's confirmation (EV 6) comes after this
      abort_stop_wait_s_ = 0.5;    // it can only come once the link is back
      stop_robot = true;
      stop_owed_ = true;
    }
    if (news.empty()) continue;
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
      say(news + (stop_robot ? " during a move: stopping the robot" : ""));
    }
    record_event("link", stop_robot ? news + " during a move: robot stopped" : news);
    lock.lock();
  }
}

void Hub::on_robot_packet(pr::SerialFromDevice&& msg, const tr::RxPacket& rx) {
  {
    const auto* st = std::get_if<pr::DeviceState>(&msg);
    std::string news;
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
          news =
              fmt::format("{}: {}{}",
                          after_silence ? fmt::format("the robot link is back after {} ms", wall_ms)
                                        : std::string("the robot's state reports skipped ahead"),
                          cut, stop_robot ? ": stopping the robot" : "");
          print = true;
          cv_.notify_all();
        } else if (jumped) {
          // the event log only: the move goes on
          news = fmt::format(
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
          news = fmt::format(
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
    if (!news.empty()) {
      if (stop_robot) {
        (void)robot_->send_realtime(pr::Realtime::kStop);
        robot_->fail_pending("the robot link was cut");
      }
      if (print) say(news);
      record_event("link", news);
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

}  // namespace scaratwin
