#include "scaratwin/transport/statements.hpp"

#include <chrono>
#include <cmath>
#include <condition_variable>
#include <fstream>

#include "scaratwin/core/units.hpp"
#include "scaratwin/kinematics/motor.hpp"

namespace scaratwin::transport {

namespace {

using namespace protocol;

Error no_robot(const char* statement, const char* which) {
  return Error{static_cast<int>(TransportError::kNotConnected),
               std::string(statement) + ": no " + which + " robot attached to this twin"};
}

Error with_context(const char* statement, const Error& e) {
  return Error{e.code, std::string(statement) + ": " + e.message};
}

template <class In>
Error unexpected(const char* statement, const char* wanted) {
  return Error{protocol_error_code(core::kErrInternal),
               std::string(statement) + ": reply was not the expected " + wanted};
}

}  // namespace

Twin::Twin(const RobotModel& model, RobotChannel* physical, SimChannel* virtual_robot,
           TwinOptions options)
    : model_(model),
      physical_(physical),
      virtual_(virtual_robot),
      options_(options),
      last_dir_(homed_directions(model)) {}

void Twin::set_directions(const MotionDirections& dir) {
  std::lock_guard lock(log_mutex_);
  last_dir_ = dir;
}

Result<PhysicalJoints> Twin::read_physical_joints() {
  constexpr const char* kName = "read_physical_joints";
  if (!physical_) return no_robot(kName, "physical");
  auto reply = physical_->request(QueryState{}, options_.reply_timeout);
  if (!reply) return with_context(kName, reply.error());
  const auto* st = std::get_if<DeviceState>(&reply->last());
  if (!st) return unexpected<SerialFromDevice>(kName, "ST");
  PhysicalJoints j;
  const std::array<double, kNumSteppers> steps{static_cast<double>(st->steps[0]),
                                               static_cast<double>(st->steps[1]),
                                               static_cast<double>(st->steps[2])};
  j.q = motors_to_joints(model_, steps, rad_to_deg(st->wrist_rad));
  j.grip_rad = st->grip_rad;
  j.seq = st->seq;
  j.device_t_us = st->t_us;
  j.flags = st->flags;
  j.queue_free = st->queue_free;
  j.rx_steady_us = reply->rx_steady_us;
  j.rx_system_us = reply->rx_system_us;
  std::lock_guard lock(log_mutex_);
  if (log_.size() >= options_.max_stored) log_.erase(log_.begin());
  log_.push_back(j);
  return j;
}

std::vector<PhysicalJoints> Twin::stored_joints() const {
  std::lock_guard lock(log_mutex_);
  return log_;
}

Result<JointsApplied> Twin::send_joints_to_virtual(const JointVector& q) {
  constexpr const char* kName = "send_joints_to_virtual";
  if (!virtual_) return no_robot(kName, "virtual");
  JointData jd;
  jd.seq = jd_seq_++;
  jd.t_us = static_cast<std::uint32_t>(steady_now_us());
  jd.q = q;
  jd.robot = options_.robot;
  auto reply = virtual_->request(jd, options_.reply_timeout);
  if (!reply) return with_context(kName, reply.error());
  const auto* ja = std::get_if<JointApplied>(&reply->last());
  if (!ja) return unexpected<TcpFromSim>(kName, "JA");
  JointsApplied out;
  out.seq = jd.seq;
  out.sent_t_us = jd.t_us;
  out.apply_t_us = ja->t_apply_us;
  out.latency_us = static_cast<std::int32_t>(ja->t_apply_us - jd.t_us);
  out.round_trip_us = reply->rx_steady_us - reply->sent_steady_us;
  return out;
}

Result<std::vector<ObjectPose>> Twin::object_positions() {
  constexpr const char* kName = "object_positions";
  if (!virtual_) return no_robot(kName, "virtual");
  auto reply = virtual_->request(QueryObjects{}, options_.reply_timeout);
  if (!reply) return with_context(kName, reply.error());
  std::vector<ObjectPose> poses;
  for (const auto& m : reply->messages) {
    if (const auto* op = std::get_if<ObjectPose>(&m)) poses.push_back(*op);
  }
  const auto* ak = std::get_if<Ack>(&reply->last());
  if (ak && ak->value && *ak->value != static_cast<std::int32_t>(poses.size())) {
    return Error{protocol_error_code(core::kErrInternal),
                 std::string(kName) + ": simulator announced " + std::to_string(*ak->value) +
                     " objects, sent " + std::to_string(poses.size())};
  }
  return poses;
}

Result<ObjectPose> Twin::object_position(std::int32_t id) {
  constexpr const char* kName = "object_position";
  if (!virtual_) return no_robot(kName, "virtual");
  auto reply = virtual_->request(QueryObjects{id}, options_.reply_timeout);
  if (!reply) return with_context(kName, reply.error());
  for (const auto& m : reply->messages) {
    if (const auto* op = std::get_if<ObjectPose>(&m); op && op->id == id) return *op;
  }
  return Error{protocol_error_code(core::kErrBadValue),
               std::string(kName) + ": no object " + std::to_string(id) + " in the scene"};
}

Result<TrajectoryLoad> Twin::load_trajectory(const JointTrajectory& trajectory) {
  constexpr const char* kName = "load_trajectory";
  if (!physical_) return no_robot(kName, "physical");
  const auto& samples = trajectory.samples;
  if (samples.empty() || samples.size() > 65535) {
    return Error{
        protocol_error_code(core::kErrBadValue),
        std::string(kName) + ": " + std::to_string(samples.size()) + " samples, need 1..65535"};
  }
  // the points, in wire units
  std::vector<TrajectoryPoint> points;
  points.reserve(samples.size());
  MotionDirections applied;  // the side of its dead band each joint's motor now leads on
  {
    std::lock_guard lock(log_mutex_);
    applied = last_dir_;
  }
  const auto& backlash = model_.calibration.backlash;
  const bool compensate = backlash != std::array<double, 3>{};
  // a calibrated backlash: the motor leads the joint by `lead` (half the dead band, signed)
  auto with_lead = [](JointVector q, const std::array<double, 3>& lead) {
    for (int j = 0; j < kNumSteppers; ++j) q[j] += lead[j];
    return q;
  };
  auto motor_point = [&](const JointVector& q_joint, const std::array<double, 3>& lead,
                         double dt_s) {
    const JointVector q = with_lead(q_joint, lead);
    TrajectoryPoint p;
    p.seq = static_cast<std::int32_t>(points.size());
    p.dt_s = dt_s;
    const auto steps = joints_to_steps(model_, q);
    p.steps = {steps[0], steps[1], steps[2]};
    p.wrist_rad = deg_to_rad(joints_to_motors(model_, q).wrist_deg);
    points.push_back(p);
  };
  auto lead_of = [&backlash](const MotionDirections& d) {
    return std::array<double, 3>{0.5 * d[0] * backlash[0], 0.5 * d[1] * backlash[1],
                                 0.5 * d[2] * backlash[2]};
  };
  // Where a joint turns, its motor must cross the dead band while the joint stays: at a point
  // where the trajectory rests, a take-up is inserted (the motors alone move the band, on a
  // smooth ramp at a quarter of their acceleration), so no point jumps; a joint that turns
  // while moving keeps its lead until the next rest (the joint trails by the band till then).
  auto at_rest = [&samples](std::size_t k) {
    for (int j = 0; j < kNumSteppers; ++j) {
      if (std::abs(samples[k].qd[j]) > 1e-6) return false;
    }
    return true;
  };
  // the side each joint moves to next after sample k (or, if it stays, the side it came from)
  auto sides_after = [&samples](std::size_t k, MotionDirections came) {
    MotionDirections next = came;
    std::array<bool, kNumSteppers> found{};
    for (std::size_t i = k + 1; i < samples.size(); ++i) {
      for (int j = 0; j < kNumSteppers; ++j) {
        const double d = samples[i].q[j] - samples[k].q[j];
        if (!found[j] && std::abs(d) > 1e-9) {
          next[j] = d > 0.0 ? 1 : -1;
          found[j] = true;
        }
      }
    }
    return next;
  };
  auto take_up = [&](const JointVector& q_hold, const MotionDirections& to) {
    const auto from_lead = lead_of(applied), to_lead = lead_of(to);
    const auto a = joints_to_steps(model_, with_lead(q_hold, from_lead));
    const auto b = joints_to_steps(model_, with_lead(q_hold, to_lead));
    const std::array<double, 3> accel{model_.motors.z.max_accel_steps_s2,
                                      model_.motors.j2.max_accel_steps_s2,
                                      model_.motors.j3.max_accel_steps_s2};
    double t = 0.1;
    for (int j = 0; j < kNumSteppers; ++j) {
      // a quintic ramp's peak acceleration is 5.77 d / T^2
      t = std::max(t, std::sqrt(5.77 * std::abs(b[j] - a[j]) / (0.25 * accel[j])));
    }
    const int n = std::max(5, static_cast<int>(std::ceil(t / 0.02)));
    const double dt = std::ceil(t / n * 1000.0) / 1000.0;
    for (int i = 1; i <= n; ++i) {
      const double u = static_cast<double>(i) / n;
      const double s = u * u * u * (10.0 + u * (-15.0 + 6.0 * u));
      std::array<double, 3> lead{};
      for (int j = 0; j < kNumSteppers; ++j)
        lead[j] = from_lead[j] + s * (to_lead[j] - from_lead[j]);
      motor_point(q_hold, lead, dt);
    }
    applied = to;
  };

  MotionDirections came = applied;  // the side each joint last moved to
  std::size_t event = 0;
  double total_s = 0.0;
  for (std::size_t k = 0; k < samples.size(); ++k) {
    std::int64_t dt_ms = 0;
    if (k == 0) {
      dt_ms = samples.size() > 1
                  ? std::llround(samples[1].t_s * 1000.0) - std::llround(samples[0].t_s * 1000.0)
                  : 100;
    } else {
      dt_ms = std::llround(samples[k].t_s * 1000.0) - std::llround(samples[k - 1].t_s * 1000.0);
    }
    dt_ms = std::clamp<std::int64_t>(dt_ms, 1, 65535);
    // The device reaches the point at whole milliseconds: take the position at that time, not
    // at the sample's own (a sample spacing of 20.05 ms sent as 20 and 21 ms would turn into
    // a 5 % speed jitter that the firmware's acceleration check refuses). Second-order Taylor
    // step from the sample's velocity and acceleration; at rest (the ends) it changes nothing.
    const double shift_s =
        static_cast<double>(std::llround(samples[k].t_s * 1000.0)) / 1000.0 - samples[k].t_s;
    JointVector q = samples[k].q;
    for (int j = 0; j < kNumJoints; ++j) {
      q[j] += samples[k].qd[j] * shift_s + 0.5 * samples[k].qdd[j] * shift_s * shift_s;
    }
    if (k > 0) track_directions(came, samples[k - 1].q, samples[k].q);
    motor_point(q, lead_of(applied), static_cast<double>(dt_ms) / 1000.0);
    TrajectoryPoint& p = points.back();
    while (event < trajectory.events.size() && trajectory.events[event].t_s <= samples[k].t_s) {
      const bool close = trajectory.events[event].action == GripperAction::kGrip;
      p.grip_rad =
          deg_to_rad(close ? model_.motors.gripper_closed_deg : model_.motors.gripper_open_deg);
      ++event;
    }
    if (compensate && (k == 0 || k + 1 == samples.size() || at_rest(k))) {
      const MotionDirections next = sides_after(k, came);
      if (next != applied) take_up(q, next);
    }
  }
  for (const TrajectoryPoint& p : points) total_s += p.dt_s;
  if (event < trajectory.events.size()) {  // events after the last sample go with it
    const bool close = trajectory.events.back().action == GripperAction::kGrip;
    points.back().grip_rad =
        deg_to_rad(close ? model_.motors.gripper_closed_deg : model_.motors.gripper_open_deg);
  }
  if (points.size() > 65535) {
    return Error{protocol_error_code(core::kErrBadValue),
                 std::string(kName) + ": " + std::to_string(points.size()) +
                     " points with the backlash take-ups, need at most 65535"};
  }
  const MotionDirections dir = applied;

  auto begin = physical_->request(TrajectoryBegin{static_cast<std::int32_t>(points.size())},
                                  options_.reply_timeout);
  if (!begin) return with_context(kName, begin.error());
  const auto* ak = std::get_if<Ack>(&begin->last());
  if (!ak || !ak->value || *ak->value < 1) {
    return Error{protocol_error_code(core::kErrInternal),
                 std::string(kName) + ": TB acknowledged without free slots"};
  }
  {
    std::lock_guard lock(log_mutex_);  // the robot takes the points from here on
    last_dir_ = dir;
  }

  // credit = free slots in the latest reply - TP sent after the request it answers
  struct Flow {
    std::mutex m;
    std::condition_variable cv;
    std::int64_t free = 0;
    std::int64_t base = 0;  // TP sent before the request of the latest reply
    std::int64_t acked = 0;
    bool polling = false;
    std::optional<Error> error;
  };
  auto flow = std::make_shared<Flow>();
  flow->free = *ak->value;
  TrajectoryLoad out;
  out.device_slots = *ak->value;
  out.duration_s = total_s;
  std::int64_t next = 0;
  const auto n = static_cast<std::int64_t>(points.size());
  auto next_poll = std::chrono::steady_clock::now();
  std::unique_lock lock(flow->m);
  while (flow->acked < n) {
    if (flow->error) return *flow->error;
    const std::int64_t credit = flow->free - (next - flow->base);
    if (next < n && credit > 0) {
      const std::int64_t sent_before = next + 1;
      lock.unlock();
      Status s = physical_->post(
          points[static_cast<std::size_t>(next)],
          [flow, sent_before](Result<RobotChannel::Reply>&& r) {
            std::lock_guard l(flow->m);
            const Ack* a = r ? std::get_if<Ack>(&r->last()) : nullptr;
            if (!r) {
              flow->error = Error{r.error().code, "TP " + std::to_string(sent_before - 1) + ": " +
                                                      r.error().message};
            } else if (!a || !a->value) {
              flow->error = Error{protocol_error_code(core::kErrInternal),
                                  "TP acknowledged without free slots"};
            } else {
              flow->free = *a->value;
              flow->base = sent_before;
              ++flow->acked;
            }
            flow->cv.notify_all();
          },
          options_.reply_timeout);
      lock.lock();
      if (!s) return with_context(kName, s.error());
      ++next;
      continue;
    }
    const auto now = std::chrono::steady_clock::now();
    if (next < n && credit <= 0 && !flow->polling && now >= next_poll) {
      // out of credit: ask for a state report, whose queue_free counts every TP sent so far
      flow->polling = true;
      next_poll = now + options_.credit_poll;
      ++out.credit_polls;
      lock.unlock();
      Status s = physical_->post(
          QueryState{},
          [flow](Result<RobotChannel::Reply>&& r) {
            std::lock_guard l(flow->m);
            flow->polling = false;
            const DeviceState* st = r ? std::get_if<DeviceState>(&r->last()) : nullptr;
            if (!r) {
              flow->error = Error{r.error().code, "QS: " + r.error().message};
            } else if (st) {
              // The device answers in order: every TP acknowledged so far was queued before
              // this report was sampled, no other was (whatever report answered the QS).
              flow->free = st->queue_free;
              flow->base = flow->acked;
            }
            flow->cv.notify_all();
          },
          options_.reply_timeout);
      lock.lock();
      if (!s) return with_context(kName, s.error());
      continue;
    }
    // wait for an acknowledgement, a poll's answer or the next poll time
    const auto progressed = [&] {
      return flow->error.has_value() || flow->acked == n ||
             (next < n && flow->free - (next - flow->base) > 0);
    };
    const auto until = next < n && !flow->polling ? next_poll : now + options_.reply_timeout;
    const std::int64_t acked_before = flow->acked;
    const bool was_polling = flow->polling;
    flow->cv.wait_until(lock, until, [&] {
      return progressed() || flow->acked != acked_before || (was_polling && !flow->polling);
    });
    if (!progressed() && flow->acked == acked_before && flow->polling == was_polling &&
        std::chrono::steady_clock::now() >= now + options_.reply_timeout) {
      return Error{protocol_error_code(core::kErrTimeout),
                   std::string(kName) + ": no progress within " +
                       std::to_string(options_.reply_timeout.count()) + " ms after point " +
                       std::to_string(flow->acked)};
    }
  }
  if (flow->error) return with_context(kName, *flow->error);
  out.points = static_cast<int>(flow->acked);
  return out;
}

Result<GripOutcome> Twin::gripper(bool close, Robots which) {
  const char* name = close ? "grip" : "release";
  const bool phys = which != Robots::kVirtual;
  const bool virt = which != Robots::kPhysical;
  if (phys && !physical_) return no_robot(name, "physical");
  if (virt && !virtual_) return no_robot(name, "virtual");
  GripOutcome out;
  if (phys) {
    const double deg = close ? model_.motors.gripper_closed_deg : model_.motors.gripper_open_deg;
    auto r = physical_->request(SetGripper{deg_to_rad(deg)}, options_.reply_timeout);
    if (!r) return with_context(name, r.error());
  }
  if (virt) {
    Grasp grasp{close};
    grasp.robot = options_.robot;
    auto r = virtual_->request(grasp, options_.reply_timeout);
    if (!r) return with_context(name, r.error());
    const auto* gs = std::get_if<GripperState>(&r->last());
    if (!gs) return unexpected<TcpFromSim>(name, "GR");
    out.virtual_closed = gs->closed;
    out.held_id = gs->held_id;
  }
  return out;
}

Result<GripOutcome> Twin::grip(Robots which) { return gripper(true, which); }
Result<GripOutcome> Twin::release(Robots which) { return gripper(false, which); }

Result<std::vector<std::uint8_t>> Twin::take_picture(const std::filesystem::path& save_as,
                                                     int width_px, int height_px) {
  constexpr const char* kName = "take_picture";
  if (!virtual_) return no_robot(kName, "virtual");
  auto reply = virtual_->request(CameraShoot{width_px, height_px}, options_.image_timeout);
  if (!reply) return with_context(kName, reply.error());
  auto* image = std::get_if<Image>(&reply->messages.back());
  if (!image) return unexpected<TcpFromSim>(kName, "IM");
  std::vector<std::uint8_t> png = std::move(image->png);
  if (!save_as.empty()) {
    std::ofstream f(save_as, std::ios::binary | std::ios::trunc);
    f.write(reinterpret_cast<const char*>(png.data()), static_cast<std::streamsize>(png.size()));
    f.close();
    if (!f) {
      return Error{protocol_error_code(core::kErrInternal),
                   std::string(kName) + ": cannot write " + save_as.string()};
    }
  }
  return png;
}

}  // namespace scaratwin::transport
