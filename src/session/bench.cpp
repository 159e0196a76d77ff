#include "scaratwin/session/bench.hpp"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <numbers>
#include <sstream>
#include <thread>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "scaratwin/hub/analysis.hpp"
#include "scaratwin/hub/hub.hpp"
#include "scaratwin/hub/process.hpp"
#include "scaratwin/hub/twin_db.hpp"
#include "scaratwin/kinematics/kinematics.hpp"
#include "scaratwin/kinematics/motor.hpp"
#include "scaratwin/session/emulator_side.hpp"
#include "scaratwin/trajectory/trajectory.hpp"
#include "scaratwin/transport/channel.hpp"
#include "scaratwin/transport/serial.hpp"
#include "scaratwin/transport/tcp.hpp"
#include "svg_plot.hpp"

namespace scaratwin::session {
namespace {

using namespace std::chrono_literals;

// The rate the Uno's UART makes for a nominal one (U2X: 16 MHz / 8 / (UBRR + 1)), as the
// firmware computes UBRR.
double uart_baud(int nominal) {
  const long ubrr = (16000000L / 4 / nominal - 1) / 2;
  return 16e6 / 8.0 / static_cast<double>(ubrr + 1);
}

// A fresh emulated robot (exact, paced 1x, no camera) and simulator (no camera) for one
// experiment, their logs tagged `tag`, once both are ready.
struct BenchRig {
  StartedEmulator robot;
  StartedSimulator sim;
};

Result<BenchRig> start_bench_rig(const BenchOptions& a, const std::filesystem::path& out,
                                 const std::string& tag) {
  auto program = [&a](const std::string& exe) { return program_path(a.bin_dir, exe); };
  auto robot = start_emulator(program("scaratwin-robot"),
                              {"--speed", "1", "--plant", "ideal", "--camera-port", "-1"},
                              out / ("robot_" + tag + ".log"), 30s);
  if (!robot) return robot.error();
  auto sim =
      start_simulator(program("scaratwin-sim"), {"--port", "0", "--http-port", "0", "--no-camera"},
                      out / ("sim_" + tag + ".log"), 30s);
  if (!sim) return sim.error();
  return BenchRig{std::move(*robot), std::move(*sim)};
}

}  // namespace

Result<RateResult> measure_rate(const RobotModel& model, const BenchOptions& a, int nominal,
                                const std::filesystem::path& out, TwinDb& db) {
  auto rig = start_bench_rig(a, out, std::to_string(nominal));
  if (!rig) return rig.error();
  HubOptions ho;
  ho.serial_device = rig->robot.ready.pty;
  ho.sim_port = rig->sim.ready.port;
  ho.report_rate_hz = a.report_hz;
  auto hub = Hub::connect(model, ho, &db);
  if (!hub) return hub.error();
  auto side = EmulatorSide::connect(rig->robot.ready.side_port);
  if (!side) return side.error();
  // the firmware answers at the old rate, then switches (CF key 11, docs/firmware.md); the pty
  // carries any rate, so the hub's end stays as it is
  if (Status s = (*hub)->set_setting(11, nominal / 100); !s) return s.error();
  std::this_thread::sleep_for(100ms);

  (*hub)->set_mirror(true);
  auto run = (*hub)->begin_run("mirror", fmt::format("bench paper: {} baud", nominal));
  if (!run) return run.error();
  const MirrorCounters before = (*hub)->mirror_counters();
  const auto until = std::chrono::steady_clock::now() + std::chrono::duration<double>(a.seconds);
  for (int k = 0; std::chrono::steady_clock::now() < until; ++k) {
    if (Status s = side->press(k % 2 == 0 ? "j2+" : "j2-", 900); !s) return s.error();
    std::this_thread::sleep_for(1000ms);
  }
  std::this_thread::sleep_for(300ms);
  const MirrorCounters after = (*hub)->mirror_counters();
  (void)(*hub)->end_run(true);
  auto lat = db.latencies(*run);
  if (!lat) return lat.error();
  RateResult r;
  r.nominal = nominal;
  r.baud = uart_baud(nominal);
  r.wire_ms = state_report_wire_s(r.baud) * 1e3;
  const LatencyFigures lf = latency_figures(*lat, state_report_wire_s(r.baud));
  r.frames = lf.device_to_sim_ms.count;
  r.lost = static_cast<std::int64_t>(after.lost - before.lost);
  r.latency_ms = lf.device_to_sim_ms;
  r.hub_to_sim_ms = lf.hub_to_sim_ms;
  return r;
}

namespace {

// ---- Fig. 15, control: time to reach a target point ----------------------------------------

// Target points: the paper's three control experiments (its Fig. 14 d-f) and two more.
std::vector<ToolPose> control_targets(int n) {
  const double pts[5][3] = {{0.2071, 0.0662, -0.0199},
                            {0.2422, -0.0421, -0.0195},
                            {0.1952, 0.0076, -0.0197},
                            {0.1500, 0.1000, 0.0000},
                            {0.1800, -0.0800, -0.0100}};
  std::vector<ToolPose> out;
  for (int k = 0; k < n && k < 5; ++k) {
    ToolPose p;
    p.x_m = pts[k][0];
    p.y_m = pts[k][1];
    p.z_m = pts[k][2];
    out.push_back(p);
  }
  return out;
}

Result<JointVector> reach(const RobotModel& model, ToolPose pose) {
  // the wrist's heading is free: the first the wrist reaches
  Result<JointVector> q = Error{IkError::kBeyondReach, "unreachable"};
  for (double yaw_deg : {0.0, 90.0, 180.0, -90.0}) {
    pose.yaw_rad = yaw_deg * std::numbers::pi / 180.0;
    q = inverse(model, pose, model.home);
    if (q) return q;
  }
  return q;
}

// The companion frame's zero, as a companion-script user works it out: the counts the switches
// set when homing (J3's with the coupling share of J2 backed off its switch).
std::array<long, 3> companion_zero(const RobotModel& model) {
  const auto sw = endstop_steps(model);
  const long j2_backed = sw[1] - model.endstops.homing_dir[1] * model.endstops.pulloff_steps;
  return {sw[0], sw[1],
          sw[2] + static_cast<long>(std::floor(model.motors.j3_per_j2_coupling *
                                               static_cast<double>(j2_backed)))};
}

void drain(transport::Link& link) {
  while (link.receive(transport::Duration(100))) {
  }
}

// The robot's port opened raw, as the paper's scripts open it. A Uno resets on the open: its
// bootloader runs about 1.5 s, then the firmware says hello once (HI=...); what it sends before
// it, and its state reports at the power-up rate, are read and dropped. A board whose
// auto-reset is cut says no hello: after 4 s the link is used as it is.
Result<std::unique_ptr<transport::SerialLink>> open_raw(const std::string& device) {
  transport::SerialOptions so;
  so.device = device;
  auto link = transport::SerialLink::create(so);
  if (!link) return link.error();
  if (Status s = (*link)->wait_connected(transport::Duration(3000)); !s) return s.error();
  const auto until = std::chrono::steady_clock::now() + 4s;
  while (std::chrono::steady_clock::now() < until) {
    auto p = (*link)->receive(transport::Duration(100));
    if (p && p->line.rfind("HI=", 0) == 0) break;
  }
  (void)(*link)->send("SR=0=\n");
  drain(**link);
  return link;
}

// The robot's state over a raw serial link: QS= until the counts are `want`, homed and at
// rest.
Status wait_counts(transport::SerialLink& link, const std::array<long, 3>& want, double timeout_s) {
  const auto until = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
  while (std::chrono::steady_clock::now() < until) {
    if (Status s = link.send("QS=\n"); !s) return s;
    for (;;) {
      auto p = link.receive(transport::Duration(500));
      if (!p) break;
      long seq = 0, t = 0, z = 0, j2 = 0, j3 = 0, w = 0, g = 0, flags = 0, q = 0;
      if (std::sscanf(p->line.c_str(), "ST=%ld=%ld=%ld=%ld=%ld=%ld=%ld=%ld=%ld=", &seq, &t, &z, &j2,
                      &j3, &w, &g, &flags, &q) == 9) {
        if (z == want[0] && j2 == want[1] && j3 == want[2] && (flags & 1) != 0 &&
            (flags & 2) == 0) {
          return Ok{};
        }
        break;
      }
    }
    std::this_thread::sleep_for(20ms);
  }
  return Error{AppError::kBench, fmt::format("the robot did not reach the counts {} {} {}", want[0],
                                             want[1], want[2])};
}

}  // namespace

Result<std::vector<ControlResult>> measure_control(const RobotModel& model, const BenchOptions& a,
                                                   const std::filesystem::path& out, TwinDb& db) {
  auto rig = start_bench_rig(a, out, "control");
  if (!rig) return rig.error();
  HubOptions ho;
  ho.serial_device = rig->robot.ready.pty;
  ho.sim_port = rig->sim.ready.port;

  std::vector<ControlResult> results;
  std::vector<JointVector> goals;
  for (const ToolPose& p : control_targets(a.targets)) {
    auto q = reach(model, p);
    if (!q)
      return Error{AppError::kBench, fmt::format("target {:.4f} {:.4f} {:.4f}: {}", p.x_m, p.y_m,
                                                 p.z_m, q.error().message)};
    goals.push_back(*q);
    ControlResult r;
    r.target = p;
    results.push_back(r);
  }
  {
    // ours: the quintic (60 samples, the shortest duration the motor limits allow) as TB/TP
    auto hub = Hub::connect(model, ho, &db);
    if (!hub) return hub.error();
    (*hub)->set_mirror(true);
    if (Status s = (*hub)->home(); !s) return s.error();
    for (std::size_t k = 0; k < goals.size(); ++k) {
      auto there = plan_quintic(model, (*hub)->physical().q, goals[k]);
      if (!there) return there.error();
      const auto t0 = std::chrono::steady_clock::now();
      auto n = (*hub)->run_trajectory(*there);
      if (!n) return n.error();
      results[k].ours_s =
          std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      results[k].ours_points = *n;
      auto back = plan_quintic(model, (*hub)->physical().q, model.home);
      if (!back) return back.error();
      if (auto b = (*hub)->run_trajectory(*back); !b) return b.error();
    }
    // the companion dialect on (the robot stays homed: the frame's zero is that homing's)
    if (Status s = (*hub)->set_setting(10, 1); !s) return s.error();
  }
  // single-class: the companion scripts' numberTran over the same port, raw. A board that
  // reset on the open homes by itself in the companion dialect, as the companion sketch does
  // in its setup(): the measure starts once it stands homed at the home pose.
  auto link = open_raw(ho.serial_device);
  if (!link) return link.error();
  const auto at_home = joints_to_steps(model, model.home);
  if (Status s = wait_counts(**link, {at_home[0], at_home[1], at_home[2]}, 120.0); !s) {
    return Error{AppError::kBench,
                 fmt::format("after the port's open: {} (the power-up homing of the companion "
                             "dialect)",
                             s.error().message)};
  }
  const auto zero = companion_zero(model);
  for (std::size_t k = 0; k < goals.size(); ++k) {
    const auto steps = joints_to_steps(model, goals[k]);
    const std::array<long, 3> target{steps[0] - zero[0], steps[1] - zero[1], steps[2] - zero[2]};
    const auto t0 = std::chrono::steady_clock::now();
    const char axis[3] = {'z', 'y', 'x'};
    for (int i = 0; i < 3; ++i) {
      if (Status s = (*link)->send(fmt::format("{}{}\n", axis[i], target[i])); !s) return s.error();
      std::this_thread::sleep_for(2s);  // the companion scripts' pause after every line
    }
    if (Status s = (*link)->send("m\n"); !s) return s.error();
    if (Status s = wait_counts(**link, {steps[0], steps[1], steps[2]}, 60.0); !s) return s.error();
    results[k].single_s =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    const auto home = joints_to_steps(model, model.home);
    if (Status s = (*link)->send(fmt::format("z{}\ny{}\nx{}\nm\n", home[0] - zero[0],
                                             home[1] - zero[1], home[2] - zero[2]));
        !s) {
      return s.error();
    }
    if (Status s = wait_counts(**link, {home[0], home[1], home[2]}, 60.0); !s) return s.error();
  }
  return results;
}

namespace {

// ---- Fig. 15, mapping: the robot's state onto the virtual robot -----------------------------

// The paper's five "sets of action commands programmed for the physical robot": here the
// robot's jog buttons (its Fig. 14 a-c moved the robot with its buttons), pressed for 0.9 s
// every second, the groups of buttons taking turns. Each starts away from the switches of the
// home pose.
struct ActionSet {
  const char* name;
  std::array<std::vector<const char*>, 2> presses;
};
const std::array<ActionSet, 5> kActionSets{{
    {"J2 back and forth", {{{"j2+"}, {"j2-"}}}},
    {"J3 back and forth", {{{"j3+"}, {"j3-"}}}},
    {"Z down and up", {{{"z-"}, {"z+"}}}},
    {"J2 and J3 together", {{{"j2+", "j3-"}, {"j2-", "j3+"}}}},
    {"Z, J2 and J3 together", {{{"z-", "j2-", "j3+"}, {"z+", "j2+", "j3-"}}}},
}};

Status run_action_set(EmulatorSide& side, const ActionSet& set, double seconds) {
  const auto until = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
  for (int k = 0; std::chrono::steady_clock::now() < until; ++k) {
    for (const char* b : set.presses[static_cast<std::size_t>(k % 2)]) {
      if (Status s = side.press(b, 900); !s) return s;
    }
    std::this_thread::sleep_for(1000ms);
  }
  std::this_thread::sleep_for(300ms);
  return Ok{};
}

// The "traditional single-class" twin: the robot reports one value per line (the firmware's
// setting 10 = 2: t, z, y, x, w, g), and the twin identifies each line by its letter and loads
// each joint value into the virtual robot as it comes, one simulator packet per value (the
// pose so far), so the virtual robot shows a sample once the packet of its last joint (w) is
// applied. The mapping delay of a sample runs from the robot's sample time (the t line, its
// clock aligned as the mixed side's) to that apply time.
class SingleClassTwin {
 public:
  SingleClassTwin(const RobotModel& model, transport::Link& robot, transport::SimChannel& sim,
                  double period_us)
      : model_(model),
        robot_(robot),
        sim_(sim),
        period_us_(period_us),
        zero_(companion_zero(model)) {
    robot_.set_packet_handler([this](transport::RxPacket&& p) { on_line(p); });
  }
  ~SingleClassTwin() {
    robot_.set_packet_handler(nullptr);
    std::this_thread::sleep_for(100ms);  // a handler running on the io thread ends
  }
  SingleClassTwin(const SingleClassTwin&) = delete;
  SingleClassTwin& operator=(const SingleClassTwin&) = delete;

  // Starts a new recording (the samples before it are forgotten).
  void begin() {
    std::lock_guard<std::mutex> lock(mu_);
    records_.clear();
    bytes_ = 0;
    t_bytes_ = 0;
    samples_ = 0;
    recording_ = true;
  }
  // The samples of the recording: one record per sample the virtual robot showed whole.
  // *bytes_per_sample: the six lines' bytes; *t_line_bytes: the t line's.
  std::vector<LatencyRecord> end(double* bytes_per_sample, double* t_line_bytes) {
    std::this_thread::sleep_for(300ms);  // the last applies
    std::lock_guard<std::mutex> lock(mu_);
    recording_ = false;
    std::vector<LatencyRecord> out;
    for (const LatencyRecord& r : records_)
      if (r.sim_apply_us != 0) out.push_back(r);
    const double n = static_cast<double>(std::max<std::size_t>(samples_, 1));
    *bytes_per_sample = static_cast<double>(bytes_) / n;
    *t_line_bytes = static_cast<double>(t_bytes_) / n;
    return out;
  }

 private:
  void on_line(const transport::RxPacket& p) {
    if (p.line.size() < 2) return;
    const char letter = p.line[0];
    long long v = 0;
    if (std::sscanf(p.line.c_str() + 1, "%lld", &v) != 1) return;
    std::unique_lock<std::mutex> lock(mu_);
    if (recording_) bytes_ += p.line.size() + 1;
    switch (letter) {
      case 't': {
        // a new sample: its number from the robot's clock (the firmware's grid), so a sample
        // that did not fit the transmit buffer shows as a gap
        if (!have_t0_) {
          t0_ = v;
          have_t0_ = true;
        }
        if (v < last_t_) wraps_ += 1LL << 32;
        last_t_ = v;
        const double k = std::round(static_cast<double>(v + wraps_ - t0_) / period_us_);
        seq_ = static_cast<std::int64_t>(k) % 65536;
        t_dev_ = v;
        t_rx_us_ = p.steady_us;
        got_ = 1;
        if (recording_) {
          ++samples_;
          t_bytes_ += p.line.size() + 1;
        }
        return;
      }
      case 'z':
      case 'y':
      case 'x': {
        const int axis = letter == 'z' ? 0 : letter == 'y' ? 1 : 2;
        steps_[axis] = static_cast<double>(zero_[static_cast<std::size_t>(axis)] + v);
        got_ |= 2 << axis;
        break;
      }
      case 'w':
        wrist_deg_ = static_cast<double>(v) / 100.0;
        got_ |= 16;
        break;
      default:
        return;  // g: the gripper, which these action sets do not move; anything else
    }
    if (!whole_) {
      whole_ = got_ == 31;  // nothing goes to the virtual robot before one whole sample
      if (!whole_) return;
    }
    // one packet per value, as it comes
    protocol::JointData jd;
    jd.seq = static_cast<std::uint16_t>(seq_);
    jd.t_us = static_cast<std::uint32_t>(p.steady_us);
    jd.q = motors_to_joints(model_, steps_, wrist_deg_);
    const bool last = letter == 'w' && got_ == 31 && recording_;
    std::size_t index = 0;
    if (last) {
      records_.push_back({seq_, t_dev_, t_rx_us_, 0});
      index = records_.size() - 1;
    }
    const std::int64_t rx_us = p.steady_us;
    lock.unlock();
    (void)sim_.post(
        jd,
        [this, last, index, rx_us](Result<transport::SimChannel::Reply>&& r) {
          if (!last || !r) return;
          const auto* ja = std::get_if<protocol::JointApplied>(&r->last());
          if (ja == nullptr) return;
          // the simulator's steady clock modulo 2^32, unwrapped near the line's arrival
          const auto delta =
              static_cast<std::int32_t>(ja->t_apply_us - static_cast<std::uint32_t>(rx_us));
          std::lock_guard<std::mutex> g(mu_);
          if (index < records_.size()) records_[index].sim_apply_us = rx_us + delta;
        },
        transport::Duration(2000));
  }

  const RobotModel& model_;
  transport::Link& robot_;
  transport::SimChannel& sim_;
  const double period_us_;
  const std::array<long, 3> zero_;
  std::mutex mu_;
  bool recording_ = false;
  std::vector<LatencyRecord> records_;
  std::size_t bytes_ = 0, t_bytes_ = 0, samples_ = 0;
  bool have_t0_ = false, whole_ = false;
  long long t0_ = 0, last_t_ = 0, wraps_ = 0, t_dev_ = 0;
  std::int64_t seq_ = 0, t_rx_us_ = 0;
  int got_ = 0;
  std::array<double, kNumSteppers> steps_{};
  double wrist_deg_ = 0.0;
};

// Reads what the robot answers on a raw link until it falls quiet.
}  // namespace

Result<std::vector<MappingResult>> measure_mapping(const RobotModel& model, const BenchOptions& a,
                                                   const std::filesystem::path& out, TwinDb& db) {
  auto rig = start_bench_rig(a, out, "mapping");
  if (!rig) return rig.error();
  HubOptions ho;
  ho.serial_device = rig->robot.ready.pty;
  ho.sim_port = rig->sim.ready.port;
  ho.report_rate_hz = a.report_hz;
  auto side = EmulatorSide::connect(rig->robot.ready.side_port);
  if (!side) return side.error();

  std::vector<MappingResult> results;
  for (int k = 0; k < a.action_sets; ++k) {
    MappingResult r;
    r.name = kActionSets[static_cast<std::size_t>(k)].name;
    results.push_back(r);
  }
  {
    // mixed: our twin, one ST packet per sample, one simulator packet per sample
    auto hub = Hub::connect(model, ho, &db);
    if (!hub) return hub.error();
    (*hub)->set_mirror(true);
    if (Status s = (*hub)->home(); !s) return s.error();
    for (std::size_t k = 0; k < results.size(); ++k) {
      MappingResult& r = results[k];
      auto run = (*hub)->begin_run("mirror", "bench paper: mapping, mixed, " + r.name);
      if (!run) return run.error();
      const MirrorCounters before = (*hub)->mirror_counters();
      const transport::LinkCounters wire_before = (*hub)->serial_counters();
      if (Status s = run_action_set(*side, kActionSets[k], a.mapping_s); !s) return s.error();
      const MirrorCounters after = (*hub)->mirror_counters();
      const transport::LinkCounters wire_after = (*hub)->serial_counters();
      r.mixed_bytes = static_cast<double>(wire_after.bytes_in - wire_before.bytes_in) /
                      static_cast<double>(std::max<std::uint64_t>(
                          wire_after.packets_in - wire_before.packets_in, 1));
      (void)(*hub)->end_run(true);
      auto lat = db.latencies(*run);
      if (!lat) return lat.error();
      // the robot's clock aligned as the baud part's, with the wire time of the reports as
      // they were (about 38 bytes near home, where the baud part takes 55, the longest)
      r.mixed = latency_figures(*lat, r.mixed_bytes * 10.0 / uart_baud(115200));
      r.mixed_lost = static_cast<std::int64_t>(after.lost - before.lost);
    }
    if (Status s = (*hub)->wait_idle(30.0); !s) return s.error();
  }
  // single-class: the robot's reports one value per line, the twin loading them one by one
  auto link = open_raw(ho.serial_device);
  if (!link) return link.error();
  (void)(*link)->send("CF=10=2=\n");
  drain(**link);
  transport::TcpClientOptions to;
  to.host = "127.0.0.1";
  to.port = ho.sim_port;
  auto tcp = transport::TcpClient::create(to);
  if (!tcp) return tcp.error();
  if (Status s = (*tcp)->wait_connected(transport::Duration(3000)); !s) return s.error();
  transport::SimChannel sim_channel(**tcp);
  if (auto hi = sim_channel.request(protocol::Hello{}, transport::Duration(3000)); !hi) {
    return hi.error();
  }
  if (auto m = sim_channel.request(protocol::SetMode{protocol::SimMode::kMirror},
                                   transport::Duration(3000));
      !m) {
    return m.error();
  }
  {
    SingleClassTwin twin(model, **link, sim_channel, 1e6 / a.report_hz);
    if (Status s = (*link)->send(fmt::format("SR={}=\n", a.report_hz)); !s) return s.error();
    std::this_thread::sleep_for(300ms);
    for (std::size_t k = 0; k < results.size(); ++k) {
      twin.begin();
      if (Status s = run_action_set(*side, kActionSets[k], a.mapping_s); !s) return s.error();
      double t_line_bytes = 0.0;
      auto records = twin.end(&results[k].single_bytes, &t_line_bytes);
      // the t line is the first line after the sample: its wire time is the earliest arrival
      results[k].single = latency_figures(records, t_line_bytes * 10.0 / uart_baud(115200));
      results[k].single_lost = results[k].single.lost_frames;
    }
  }
  (void)(*link)->send("SR=0=\nCF=10=0=\n");
  drain(**link);
  return results;
}

std::string rate_plot_svg(const std::vector<RateResult>& results, int report_hz) {
  std::vector<svg::Series> s(3);
  s[0] = {"latency p50", "#1f77b4", {}, {}, false};
  s[1] = {"latency p99", "#d62728", {}, {}, false};
  s[2] = {"wire time of one report", "#555555", {}, {}, true};
  for (const RateResult& r : results) {
    if (r.frames == 0) continue;
    const double x = std::log10(r.baud);
    s[0].x.push_back(x);
    s[0].y.push_back(r.latency_ms.p50);
    s[1].x.push_back(x);
    s[1].y.push_back(r.latency_ms.p99);
    s[2].x.push_back(x);
    s[2].y.push_back(r.wire_ms);
  }
  return svg::line_chart(
      fmt::format("Mirror latency against the serial rate ({} Hz reports)", report_hz),
      "log10(baud)", "ms", s, 560, 300);
}

std::string control_plot_svg(const std::vector<ControlResult>& results) {
  std::vector<svg::Series> cs(2);
  cs[0] = {"mixed packets (TB/TP quintic)", "#1f77b4", {}, {}, false};
  cs[1] = {"single-class (z, y, x, m; 2 s pauses)", "#d62728", {}, {}, false};
  for (std::size_t k = 0; k < results.size(); ++k) {
    for (int i = 0; i < 2; ++i) cs[i].x.push_back(static_cast<double>(k + 1));
    cs[0].y.push_back(results[k].ours_s);
    cs[1].y.push_back(results[k].single_s);
  }
  return svg::line_chart("Fig. 15 (control): time to reach each target point", "target point", "s",
                         cs, 560, 300);
}

std::string mapping_plot_svg(const std::vector<MappingResult>& results) {
  std::vector<svg::Series> ms(4);
  ms[0] = {"mixed packets, mean", "#1f77b4", {}, {}, false};
  ms[1] = {"single-class, mean", "#d62728", {}, {}, false};
  ms[2] = {"mixed packets, p99", "#1f77b4", {}, {}, true};
  ms[3] = {"single-class, p99", "#d62728", {}, {}, true};
  for (std::size_t k = 0; k < results.size(); ++k) {
    const double set = static_cast<double>(k + 1);
    for (auto& sr : ms) sr.x.push_back(set);
    ms[0].y.push_back(results[k].mixed.device_to_sim_ms.mean);
    ms[1].y.push_back(results[k].single.device_to_sim_ms.mean);
    ms[2].y.push_back(results[k].mixed.device_to_sim_ms.p99);
    ms[3].y.push_back(results[k].single.device_to_sim_ms.p99);
  }
  return svg::line_chart("Fig. 15 (mapping): robot state -> virtual robot, per action set",
                         "action set", "ms", ms, 560, 300);
}

}  // namespace scaratwin::session
