// The hub's virtual-robot side: statements to the simulator over the TCP link (mode, twin
// phase, cubes, camera, grasp, simulated trajectories).
#include <utility>  // before Boost headers (Boost 1.74 with g++ 12)

#include "scaratwin/hub/hub.hpp"

#include <fmt/format.h>

#include "hub_internal.hpp"
#include "scaratwin/kinematics/kinematics.hpp"
#include "scaratwin/kinematics/workcell.hpp"

namespace scaratwin {

namespace pr = protocol;
namespace tr = transport;
using hub_detail::hub_error;
using hub_detail::ms;
using std::chrono::milliseconds;

// --- virtual robot ----------------------------------------------------------------------------

namespace {

template <class T>
Result<T> sim_reply(const char* what, Result<tr::SimChannel::Reply> r) {
  if (!r) return hub_error(fmt::format("simulator {}: {}", what, r.error().message));
  if (const T* v = std::get_if<T>(&r->last())) return *v;
  return hub_error(fmt::format("simulator {}: unexpected reply", what));
}

}  // namespace

Status Hub::place_virtual(const JointVector& q) {
  if (Status s = sim_mode(pr::SimMode::kMirror); !s) return s;
  pr::JointData jd;
  jd.t_us = static_cast<std::uint32_t>(tr::steady_now_us());
  jd.q = q;
  jd.robot = options_.sim_robot;
  auto ja =
      sim_reply<pr::JointApplied>("place the virtual robot", sim_->request(jd, milliseconds(2000)));
  if (!ja) return ja.error();
  return sim_mode(pr::SimMode::kSimulate);
}

Status Hub::set_twin_phase(pr::TwinPhase phase) {
  // an un-homed robot's joints are its counts since power-up, not where it is: the simulator
  // hears that it homes, whatever the phase, until it has (home() restores the phase)
  const pr::TwinPhase said = robot_homed_ ? phase : pr::TwinPhase::kHoming;
  auto r = sim_reply<pr::Ack>(
      "twin phase", sim_->request(pr::SetTwinPhase{said, options_.sim_robot}, milliseconds(2000)));
  if (!r) return r.error();
  if (phase != pr::TwinPhase::kHoming) twin_phase_ = phase;
  return Ok{};
}

Status Hub::sim_mode(pr::SimMode mode) {
  auto r = sim_reply<pr::Ack>(
      "mode", sim_->request(pr::SetMode{mode, options_.sim_robot}, milliseconds(2000)));
  if (!r) return r.error();
  return Ok{};
}

Result<int> Hub::spawn_cube(CubeColor color, double x_m, double y_m) {
  const auto w = base_to_world(options_.base, {x_m, y_m, 0.0});
  auto reply = sim_->request(pr::SpawnCube{color, w[0], w[1]}, milliseconds(2000));
  if (!reply && reply.error().code == protocol_error_code(pr::core::kErrBadValue)) {
    // the simulator says why in its log; the wire says only which field (docs/protocol.md)
    return hub_error(fmt::format(
        "simulator spawn: the simulator refused a cube at ({:.4f}, {:.4f}) m{}: off its table, "
        "or closer than a cube's diagonal to another cube ({})",
        x_m, y_m,
        options_.sim_robot == 0
            ? std::string()
            : fmt::format(" in robot {}'s base frame, ({:.4f}, {:.4f}) m in the world",
                          options_.sim_robot, w[0], w[1]),
        reply.error().message));
  }
  auto r = sim_reply<pr::Ack>("spawn", std::move(reply));
  if (!r) return r.error();
  return r->value.value_or(-1);
}

Status Hub::reset_scene() {
  auto reply = sim_->request(pr::ResetScene{}, milliseconds(2000));
  if (!reply && options_.sim_robot != 0 &&
      reply.error().code == protocol_error_code(pr::core::kErrAccess)) {
    return hub_error(fmt::format(
        "simulator reset: the robots of a workcell share its scene, and only the hub of its "
        "first robot (0) resets it; this hub drives robot {} ({})",
        options_.sim_robot, reply.error().message));
  }
  auto r = sim_reply<pr::Ack>("reset", std::move(reply));
  if (!r) return r.error();
  std::lock_guard<std::mutex> lock(mu_);
  sim_grip_closed_ = false;
  return Ok{};
}

Result<pr::ArmContacts> Hub::arm_contacts() {
  return sim_reply<pr::ArmContacts>("arm contacts",
                                    sim_->request(pr::QueryContacts{}, milliseconds(2000)));
}

Result<std::vector<pr::ObjectPose>> Hub::objects() {
  auto r = statements_->object_positions();
  if (!r) return hub_error(fmt::format("simulator objects: {}", r.error().message));
  std::vector<pr::ObjectPose> in_base = *r;
  for (pr::ObjectPose& o : in_base) {
    const auto p = world_to_base(options_.base, {o.x_m, o.y_m, o.z_m});
    o.x_m = p[0];
    o.y_m = p[1];
    o.z_m = p[2];
    o.yaw_rad = wrap_angle(o.yaw_rad - options_.base.yaw_rad);
  }
  return in_base;
}

Result<std::string> Hub::shoot(int width_px, int height_px) {
  auto r = statements_->take_picture({}, width_px, height_px);
  if (!r) return hub_error(fmt::format("simulator camera: {}", r.error().message));
  std::string png(r->begin(), r->end());
  std::lock_guard<std::mutex> lock(mu_);
  if (db_ != nullptr && run_ != 0) {
    (void)db_->add_image(run_, static_cast<double>(tr::steady_now_us() - run_start_us_) / 1e6,
                         "camera.png", png);
  }
  return png;
}

Result<tr::GripOutcome> Hub::sim_grasp(bool close) {
  auto r =
      close ? statements_->grip(tr::Robots::kVirtual) : statements_->release(tr::Robots::kVirtual);
  if (!r) return hub_error(fmt::format("simulator gripper: {}", r.error().message));
  std::lock_guard<std::mutex> lock(mu_);
  sim_grip_closed_ = close;
  return *r;
}

Result<pr::SimState> Hub::sim_state() {
  return sim_reply<pr::SimState>(
      "state", sim_->request(pr::QueryState{options_.sim_robot}, milliseconds(2000)));
}

Status Hub::simulate_trajectory(const JointTrajectory& traj, double speed) {
  if (traj.samples.empty()) return Ok{};
  if (!(speed > 0.0)) return hub_error(fmt::format("speed {} must be > 0", speed));
  // The virtual robot starts where the plan starts. A plan made from the physical robot's
  // pose after the scene was reset (virtual robot at home) would otherwise begin with a jump
  // that the simulated actuators make in a few tens of ms and the physical robot never makes.
  if (Status s = place_virtual(traj.samples.front().q); !s) return s;
  // The targets keep the plan's spacing in time. When the hub falls behind it by more than
  // kLateMargin (the hub or the simulator descheduled on a loaded machine, a slow reply), the
  // rest of the plan is held back by as much: the targets it missed, sent back to back, would
  // make the virtual robot's servos chase a target far ahead and cut the plan's curves (15 mm
  // off the path after a stall of a few hundred ms), so the prediction would not be the plan's.
  constexpr auto kLateMargin = std::chrono::milliseconds(5);
  auto start = std::chrono::steady_clock::now();
  size_t next_event = 0;
  const auto record_state = [&]() -> Status {
    auto st = sim_state();
    if (!st) return st.error();
    std::lock_guard<std::mutex> lock(mu_);
    add_sample(SampleSource::kVirtual,
               static_cast<double>(tr::steady_now_us() - run_start_us_) / 1e6, st->seq, st->q,
               st->grip_closed ? model_.motors.gripper_closed_deg : model_.motors.gripper_open_deg);
    return Ok{};
  };
  for (size_t k = 0; k < traj.samples.size(); ++k) {
    const JointSample& s = traj.samples[k];
    const auto due = start + std::chrono::microseconds(static_cast<long long>(s.t_s / speed * 1e6));
    const auto now = std::chrono::steady_clock::now();
    if (now > due + kLateMargin) {
      start += now - due;
    } else {
      std::this_thread::sleep_until(due);
    }
    pr::JointTargets tj;
    tj.seq = static_cast<std::uint16_t>(k);
    tj.t_us = static_cast<std::uint32_t>(tr::steady_now_us());
    tj.q = s.q;
    tj.robot = options_.sim_robot;
    {
      std::lock_guard<std::mutex> lock(mu_);
      add_sample(SampleSource::kPlanned,
                 static_cast<double>(tr::steady_now_us() - run_start_us_) / 1e6,
                 static_cast<std::int64_t>(k), s.q, 0.0);
    }
    auto ja = sim_reply<pr::JointApplied>("joint targets", sim_->request(tj, milliseconds(2000)));
    if (!ja) return ja.error();
    while (next_event < traj.events.size() && traj.events[next_event].t_s <= s.t_s + 1e-9) {
      const bool close = traj.events[next_event].action == GripperAction::kGrip;
      auto g = sim_grasp(close);
      if (!g) return g.error();
      record_event("sim-gripper", close ? fmt::format("grasp: holding cube {}", g->held_id)
                                        : std::string("release"));
      ++next_event;
    }
    if (k % 2 == 0 || k + 1 == traj.samples.size()) {
      if (Status st = record_state(); !st) return st;
    }
  }
  // let the servos settle on the last target.
  std::this_thread::sleep_for(milliseconds(static_cast<long long>(300 / speed)));
  return record_state();
}

}  // namespace scaratwin
