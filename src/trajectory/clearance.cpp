// Clearance between the arms of a workcell along their paths: see clearance.hpp.
#include "scaratwin/trajectory/clearance.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include <fmt/format.h>

#include "scaratwin/core/error_codes.hpp"

namespace scaratwin {
namespace {

Error bad(std::string message) {
  return Error{static_cast<int>(PlanError::kBadArgument), std::move(message)};
}

// The most any point of the arm's polyline moves while its joints go linearly from q0 to q1
// (m): each link end turns with the sum of the joint angles before it, and a point on a circle
// of radius a moves at most a |dheading|.
double arm_move_bound(const RobotModel& model, const JointVector& q0, const JointVector& q1) {
  double bound = 0.0, dheading = 0.0;
  for (int i = 1; i < kNumJoints; ++i) {
    dheading += q1[i] - q0[i];
    bound += std::abs(model.dh[i].a_m) * std::abs(dheading);
  }
  return bound;
}

JointVector at(const RobotMotion& m, double t_s) {
  return sample_at(*m.trajectory, t_s - m.start_s);
}

}  // namespace

Result<ClearanceReport> check_clearance(const Workcell& w, const std::vector<RobotMotion>& motions,
                                        const ClearanceOptions& o) {
  const int n = static_cast<int>(w.robots.size());
  if (static_cast<int>(motions.size()) != n) {
    return bad(fmt::format("clearance: {} motions for a workcell of {} robots (one each)",
                           motions.size(), n));
  }
  if (!(o.clearance_m >= 0.0) || !std::isfinite(o.clearance_m) || !(o.max_step_m > 0.0) ||
      !std::isfinite(o.max_step_m)) {
    return bad(
        fmt::format("clearance: clearance {} m and step {} m (want clearance >= 0 and a "
                    "finite step > 0)",
                    o.clearance_m, o.max_step_m));
  }
  // the grid: every sample time of every trajectory, in the common time
  std::vector<double> grid;
  for (int r = 0; r < n; ++r) {
    const RobotMotion& m = motions[r];
    if (m.trajectory == nullptr || m.trajectory->samples.empty()) {
      return bad(
          fmt::format("clearance: robot '{}' has no trajectory (a robot that stands "
                      "still is one sample)",
                      w.robots[r].name));
    }
    if (!std::isfinite(m.start_s)) {
      return bad(fmt::format("clearance: robot '{}' starts at {} s", w.robots[r].name, m.start_s));
    }
    for (const JointSample& s : m.trajectory->samples) grid.push_back(m.start_s + s.t_s);
  }
  std::sort(grid.begin(), grid.end());
  grid.erase(std::unique(grid.begin(), grid.end()), grid.end());

  ClearanceReport report;
  report.closest.bound_m = INFINITY;
  std::vector<JointVector> q0(n), q1(n);
  std::vector<double> move(n);
  const auto look = [&](double t, const std::vector<JointVector>& q,
                        const std::vector<double>& moves) {
    ++report.looks;
    for (int a = 0; a < n; ++a) {
      for (int b = a + 1; b < n; ++b) {
        const double d = arm_distance(w, a, q[a], b, q[b]);
        const double bound = d - moves[a] - moves[b];
        if (bound < report.closest.bound_m) {
          report.closest = ArmApproach{t, a, b, d, bound, q[a], q[b]};
        }
        if (!report.first && bound < o.clearance_m) {
          report.first = ArmApproach{t, a, b, d, bound, q[a], q[b]};
        }
      }
    }
  };
  for (std::size_t k = 0; k + 1 < grid.size(); ++k) {
    const double t0 = grid[k], t1 = grid[k + 1];
    double most = 0.0;
    for (int r = 0; r < n; ++r) {
      q0[r] = at(motions[r], t0);
      q1[r] = at(motions[r], t1);
      most = std::max(most, arm_move_bound(w.robots[r].model, q0[r], q1[r]));
    }
    // within [t0, t1] every trajectory is one linear piece: split it evenly until no arm moves
    // more than the step between two looks
    const int parts = std::max(1, static_cast<int>(std::ceil(most / o.max_step_m)));
    std::vector<JointVector> q(n);
    for (int p = 0; p < parts; ++p) {
      const double f0 = static_cast<double>(p) / parts, f1 = static_cast<double>(p + 1) / parts;
      for (int r = 0; r < n; ++r) {
        JointVector a{}, b{};
        for (int j = 0; j < kNumJoints; ++j) {
          a[j] = q0[r][j] + f0 * (q1[r][j] - q0[r][j]);
          b[j] = q0[r][j] + f1 * (q1[r][j] - q0[r][j]);
        }
        q[r] = a;
        move[r] = arm_move_bound(w.robots[r].model, a, b);
      }
      look(t0 + f0 * (t1 - t0), q, move);
    }
  }
  // the end (or the only time): everyone stands
  std::vector<JointVector> q_end(n);
  for (int r = 0; r < n; ++r) q_end[r] = at(motions[r], grid.back());
  look(grid.back(), q_end, std::vector<double>(n, 0.0));
  return report;
}

Status clearance_status(const Workcell& w, const ClearanceReport& report,
                        const ClearanceOptions& o) {
  if (!report.first) return Ok{};
  const ArmApproach& f = *report.first;
  return Error{static_cast<int>(PlanError::kCollision),
               fmt::format("robots '{}' and '{}' would come closer than the clearance of {:.1f} "
                           "mm at {:.2f} s of their paths ({:.1f} mm apart there and moving, "
                           "possibly {:.1f} mm before the next look): nothing was sent",
                           w.robots[f.robot_a].name, w.robots[f.robot_b].name, o.clearance_m * 1e3,
                           f.t_s, f.distance_m * 1e3, std::max(0.0, f.bound_m) * 1e3)};
}

}  // namespace scaratwin
