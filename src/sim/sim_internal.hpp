// Helpers shared by the Simulation's source files (simulation.cpp, motion.cpp, scene.cpp).
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <string>

#include <fmt/format.h>

#include "scaratwin/sim/simulation.hpp"

namespace scaratwin::sim::detail {

inline Error sim_error(SimError code, std::string message) {
  return Error{static_cast<int>(code), std::move(message)};
}

inline bool finite(const JointVector& q) {
  return std::all_of(q.begin(), q.end(), [](double v) { return std::isfinite(v); });
}

inline Error implausible(const RobotModel& robot, const JointVector& q, int j) {
  const JointLimit& l = robot.limits[static_cast<std::size_t>(j)];
  const double span = l.max - l.min;
  return sim_error(
      SimError::kBadArgument,
      fmt::format("joint {} = {} is not a value the robot can have (its limits are "
                  "{} .. {}; values beyond {} .. {} are refused)",
                  j + 1, q[static_cast<std::size_t>(j)], l.min, l.max, l.min - span, l.max + span));
}

// Linear interpolation of position and velocity; `hint` speeds up monotonic queries.
inline void sample(const JointTrajectory& t, double t_s, std::size_t& hint, JointVector& q,
                   JointVector& qd) {
  const auto& s = t.samples;
  if (t_s <= s.front().t_s) {
    q = s.front().q;
    qd = s.front().qd;
    return;
  }
  if (t_s >= s.back().t_s) {
    q = s.back().q;
    qd = JointVector{};
    return;
  }
  if (hint >= s.size() - 1 || s[hint].t_s > t_s) hint = 0;
  while (hint + 1 < s.size() - 1 && s[hint + 1].t_s <= t_s) ++hint;
  const JointSample& a = s[hint];
  const JointSample& b = s[hint + 1];
  const double u = (t_s - a.t_s) / (b.t_s - a.t_s);
  for (int j = 0; j < kNumJoints; ++j) {
    q[j] = a.q[j] + u * (b.q[j] - a.q[j]);
    qd[j] = a.qd[j] + u * (b.qd[j] - a.qd[j]);
  }
}

}  // namespace scaratwin::sim::detail
