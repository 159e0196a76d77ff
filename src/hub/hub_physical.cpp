// The hub's physical robot: its state, requests, homing, jogging and the trajectories it runs
// (streamed with credit flow control, watched for progress, lost steps and desync). The rest
// of the hub is in hub.cpp (connect, runs, mirror) and hub_virtual.cpp (the virtual robot).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <thread>

#include <fmt/format.h>

#include "hub_internal.hpp"
#include "scaratwin/core/units.hpp"
#include "scaratwin/hub/analysis.hpp"
#include "scaratwin/hub/hub.hpp"

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

// A command refused because the robot's reports stopped (docs/protocol.md 11.1).
constexpr const char* kRobotSilent =
    "the robot link is silent (no state report: cut or unplugged): nothing moved";

// Longest time between two trajectory points sent to the robot (the firmware's limit is 5 s).
constexpr double kLongestPointS = 4.0;

}  // namespace

// --- physical robot ---------------------------------------------------------------------------

PhysicalState Hub::physical() const {
  std::lock_guard<std::mutex> lock(mu_);
  return physical_;
}

Result<PhysicalState> Hub::fresh_physical(double timeout_s) {
  std::unique_lock<std::mutex> lock(mu_);
  const std::uint64_t n = state_count_;
  if (!cv_.wait_for(lock, ms(timeout_s), [&] { return state_count_ > n || interrupted_; })) {
    // the link watch already knows: say what it knows rather than what this wait saw
    if (robot_silent_) return hub_error(kRobotSilent);
    return hub_error(fmt::format("no state report from the robot within {} s", timeout_s));
  }
  if (interrupted_) return hub_error(kInterrupted);
  return physical_;
}

Result<PhysicalState> Hub::motion_start(double timeout_s) {
  auto now = fresh_physical(timeout_s);
  if (!now) return now;
  if ((now->raw.flags & pr::state_flags::kHomed) == 0) {
    return Error{protocol_error_code(pr::core::kErrNotHomed),
                 "the robot is not homed: its counts are no joint angles until it is (it "
                 "powered up or reset); home it first (`home`)"};
  }
  return now;
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
    return hub_error(kRobotSilent);
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
