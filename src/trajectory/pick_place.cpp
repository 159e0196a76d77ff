// Pick-and-place builder: one timed joint trajectory with gripper events.
#include <fmt/format.h>

#include "scaratwin/trajectory/trajectory.hpp"

namespace scaratwin {

Result<JointTrajectory> plan_pick_place(const RobotModel& model, const JointVector& q0,
                                        const PickPlaceRequest& r) {
  if (!(r.approach_height_m > 0.0) || !(r.grip_dwell_s >= 0.0)) {
    return Error{static_cast<int>(PlanError::kBadArgument),
                 fmt::format("approach height {} m must be > 0 and dwell {} s >= 0",
                             r.approach_height_m, r.grip_dwell_s)};
  }
  const auto above = [&](ToolPose p) {
    p.z_m += r.approach_height_m;
    return p;
  };
  const TrapezoidOptions joint_opts{r.dt_s, r.speed_scale, r.accel_scale};
  const LineOptions line_opts{0.001, r.dt_s, r.speed_scale, r.accel_scale};
  JointTrajectory out;
  out.samples.push_back(JointSample{0.0, q0, {}, {}});

  // a labelled step: the error names the stage that failed.
  const auto step = [&](const char* stage, Result<JointTrajectory> seg) -> Status {
    if (!seg) return Error{seg.error().code, fmt::format("{}: {}", stage, seg.error().message)};
    append(out, *seg);
    return Ok{};
  };
  const auto joint_move = [&](const char* stage, const ToolPose& p) -> Status {
    const JointVector from = out.samples.back().q;
    auto q = inverse(model, p, from);
    if (!q) return Error{q.error().code, fmt::format("{}: {}", stage, q.error().message)};
    return step(stage, plan_trapezoid(model, from, *q, joint_opts));
  };
  const auto line = [&](const char* stage, const ToolPose& p) -> Status {
    return step(stage, plan_line(model, out.samples.back().q, p, line_opts));
  };
  const auto gripper = [&](GripperAction a) {
    out.events.push_back(GripperEvent{out.duration_s(), a});
    append_dwell(out, r.grip_dwell_s);
  };

  if (Status s = joint_move("approach above the pick point", above(r.pick)); !s) return s.error();
  if (Status s = line("descend to the pick point", r.pick); !s) return s.error();
  gripper(GripperAction::kGrip);
  if (Status s = line("lift from the pick point", above(r.pick)); !s) return s.error();
  if (Status s = joint_move("travel above the place point", above(r.place)); !s) {
    return s.error();
  }
  if (Status s = line("descend to the place point", r.place); !s) return s.error();
  gripper(GripperAction::kRelease);
  if (Status s = line("retreat from the place point", above(r.place)); !s) return s.error();
  return out;
}

}  // namespace scaratwin
