// Several arms sorting together: see workcell_plan.hpp.
#include "scaratwin/trajectory/workcell_plan.hpp"

#include <cmath>
#include <limits>

#include <fmt/format.h>

#include "scaratwin/core/error_codes.hpp"
#include "scaratwin/core/units.hpp"

namespace scaratwin {
namespace {

double mm(double m) { return m * 1e3; }

// A tool pose of W in robot `r`'s base frame, turned by the quarter turn (a cube's grasp is
// the same every 90 degrees) whose inverse kinematics lies within the limits nearest to
// `seed`; an error when none does.
Result<ToolPose> in_base(const Workcell& w, int r, const ToolPose& p_W, const JointVector& seed) {
  const BasePose& b = w.robots[r].base;
  const RobotModel& m = w.robots[r].model;
  const auto p = world_to_base(b, {p_W.x_m, p_W.y_m, p_W.z_m});
  Result<ToolPose> best = Error{static_cast<int>(PlanError::kUnreachable), "unreachable"};
  double best_d = std::numeric_limits<double>::infinity();
  for (int k = 0; k < 4; ++k) {
    const ToolPose pose{p[0], p[1], p[2], wrap_angle(p_W.yaw_rad - b.yaw_rad + k * kPi / 2)};
    auto q = inverse(m, pose, seed);
    if (!q) {
      if (k == 0) best = q.error();
      continue;
    }
    const double d = joint_distance2(*q, seed);
    if (d < best_d) {
      best_d = d;
      best = pose;
    }
  }
  return best;
}

bool reaches(const Workcell& w, int r, const ToolPose& p_W) {
  return in_base(w, r, p_W, w.robots[r].model.home).ok();
}

// Robot r's timeline with `segment` starting at `start_s` (standing until then).
JointTrajectory extended(const JointTrajectory& timeline, double start_s,
                         const JointTrajectory& segment) {
  JointTrajectory out = timeline;
  const double wait = start_s - out.duration_s();
  if (wait > 1e-9) append_dwell(out, wait);
  append(out, segment);
  return out;
}

}  // namespace

Result<std::vector<int>> assign_by_reach(const Workcell& w,
                                         const std::vector<WorkcellTask>& tasks) {
  const int n = static_cast<int>(w.robots.size());
  std::vector<int> count(n, 0), out;
  for (const WorkcellTask& t : tasks) {
    int best = -1;
    double best_d = std::numeric_limits<double>::infinity();
    for (int r = 0; r < n; ++r) {
      if (!reaches(w, r, t.pick_W) || !reaches(w, r, t.place_W)) continue;
      const double d =
          std::hypot(t.pick_W.x_m - w.robots[r].base.x_m, t.pick_W.y_m - w.robots[r].base.y_m);
      if (best < 0 || count[r] < count[best] || (count[r] == count[best] && d < best_d)) {
        best = r;
        best_d = d;
      }
    }
    if (best < 0) {
      return Error{static_cast<int>(PlanError::kUnreachable),
                   fmt::format("{}: no robot reaches both its pick at ({:.1f}, {:.1f}) mm and "
                               "its place at ({:.1f}, {:.1f}) mm (robots: {})",
                               t.what, mm(t.pick_W.x_m), mm(t.pick_W.y_m), mm(t.place_W.x_m),
                               mm(t.place_W.y_m), robot_names(w))};
    }
    ++count[best];
    out.push_back(best);
  }
  return out;
}

Result<WorkcellPlan> plan_workcell_sort(const Workcell& w, const std::vector<WorkcellTask>& tasks,
                                        const std::vector<JointVector>& start,
                                        const WorkcellPlanOptions& o) {
  const int n = static_cast<int>(w.robots.size());
  if (static_cast<int>(start.size()) != n) {
    return Error{
        static_cast<int>(PlanError::kBadArgument),
        fmt::format("workcell plan: {} start poses for a workcell of {} robots", start.size(), n)};
  }
  if (!(o.delay_step_s > 0.0) || !(o.max_delay_s >= 0.0)) {
    return Error{static_cast<int>(PlanError::kBadArgument),
                 fmt::format("workcell plan: delay step {} s and most delay {} s (want a step "
                             "> 0 and a most >= 0)",
                             o.delay_step_s, o.max_delay_s)};
  }
  auto assigned = assign_by_reach(w, tasks);
  if (!assigned) return assigned.error();
  WorkcellPlan plan;
  plan.robot_of_task = *assigned;
  plan.timeline.resize(n);
  std::vector<JointVector> q = start;
  for (int r = 0; r < n; ++r) plan.timeline[r].samples.push_back(JointSample{0.0, q[r], {}, {}});

  // Schedules `segment` for robot r at the earliest start from its ready time on at which all
  // timelines keep the clearance.
  const auto schedule = [&](int r, const JointTrajectory& segment,
                            const std::string& what) -> Result<double> {
    const double ready = plan.timeline[r].duration_s();
    JointTrajectory candidate;
    std::vector<RobotMotion> motions(n);
    for (int i = 0; i < n; ++i) motions[i] = RobotMotion{&plan.timeline[i], 0.0};
    motions[r].trajectory = &candidate;
    for (int k = 0;; ++k) {
      const double s = ready + k * o.delay_step_s;
      candidate = extended(plan.timeline[r], s, segment);
      auto report = check_clearance(w, motions, o.clearance);
      if (!report) return report.error();
      if (!report->first) {
        plan.timeline[r] = std::move(candidate);
        return s;
      }
      if (s - ready >= o.max_delay_s) {
        return Error{static_cast<int>(PlanError::kCollision),
                     fmt::format("{} (robot '{}'): no start within {:.1f} s of waiting keeps the "
                                 "arms apart: {}",
                                 what, w.robots[r].name, o.max_delay_s,
                                 clearance_status(w, *report, o.clearance).error().message)};
      }
    }
  };

  // Plans task i for robot r from where r is and schedules it.
  const auto plan_for = [&](int i, int r) -> Status {
    const RobotModel& m = w.robots[r].model;
    PickPlaceRequest req = o.pick_place;
    auto pick = in_base(w, r, tasks[i].pick_W, q[r]);
    auto place = pick ? in_base(w, r, tasks[i].place_W, q[r]) : pick;
    if (!place) {
      return Error{place.error().code, fmt::format("{} (robot '{}'): {}", tasks[i].what,
                                                   w.robots[r].name, place.error().message)};
    }
    req.pick = *pick;
    req.place = *place;
    auto traj = plan_pick_place(m, q[r], req);
    if (traj && o.home_after_each) {
      auto home = plan_quintic(m, traj->samples.back().q, m.home);
      if (!home) {
        traj = home.error();
      } else {
        append(*traj, *home);
      }
    }
    if (!traj) {
      return Error{traj.error().code, fmt::format("{} (robot '{}'): {}", tasks[i].what,
                                                  w.robots[r].name, traj.error().message)};
    }
    auto s = schedule(r, *traj, tasks[i].what);
    if (!s) return s.error();
    q[r] = traj->samples.back().q;
    plan.tasks.push_back(PlannedTask{i, r, *s, std::move(*traj)});
    return Ok{};
  };

  for (int i = 0; i < static_cast<int>(tasks.size()); ++i) {
    // its robot; when that one cannot start it within the most delay (an arm stands in its
    // way), the next robot that reaches it, in the workcell's order
    const int first = plan.robot_of_task[i];
    Status done = plan_for(i, first);
    const bool blocked = !done && done.error().code == static_cast<int>(PlanError::kCollision);
    bool taken = false;
    for (int r = 0; blocked && !taken && r < n; ++r) {
      if (r == first || !reaches(w, r, tasks[i].pick_W) || !reaches(w, r, tasks[i].place_W)) {
        continue;
      }
      if (plan_for(i, r).ok()) {
        plan.robot_of_task[i] = r;
        taken = true;
      }
    }
    if (!done && !taken) return done.error();
  }
  // every robot that moved goes home at the end, scheduled the same way
  for (int r = 0; r < n; ++r) {
    const RobotModel& m = w.robots[r].model;
    if (joint_distance2(q[r], m.home) < 1e-18) continue;
    auto home = plan_quintic(m, q[r], m.home);
    if (!home) {
      return Error{home.error().code,
                   fmt::format("home (robot '{}'): {}", w.robots[r].name, home.error().message)};
    }
    auto s = schedule(r, *home, "home");
    if (!s) return s.error();
    q[r] = m.home;
  }
  std::vector<RobotMotion> motions(n);
  for (int r = 0; r < n; ++r) {
    motions[r] = RobotMotion{&plan.timeline[r], 0.0};
    plan.makespan_s = std::max(plan.makespan_s, plan.timeline[r].duration_s());
  }
  auto report = check_clearance(w, motions, o.clearance);
  if (!report) return report.error();
  plan.clearance = *report;
  return plan;
}

}  // namespace scaratwin
