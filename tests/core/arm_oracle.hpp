// An oracle for the workcell's arms in the tests (test_clearance.cpp, test_workcell_plan.cpp):
// the paper's closed-form planar kinematics (DESIGN.md: x = a1 + a2 cos q2 + a3 cos(q2 + q3),
// ...) and distances between links by clamped segment parameters, written apart from the
// workcell's own code.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <string>

#include "scaratwin/core/units.hpp"
#include "scaratwin/kinematics/workcell.hpp"

namespace scaratwin::test {

using P = std::array<double, 2>;

// Two paper robots: "left" at the origin, "right" at (x, y) mm turned by yaw_deg, its
// description said to come from `right_file` (for messages).
inline Workcell two_robots(double x_mm, double y_mm, double yaw_deg,
                           const std::string& right_file = "") {
  Workcell w = single_robot_workcell(paper_robot());
  w.robots[0].name = "left";
  w.robots.push_back(RobotInstance{"right",
                                   BasePose{x_mm / 1000.0, y_mm / 1000.0, 0.0, deg_to_rad(yaw_deg)},
                                   paper_robot(), right_file});
  return w;
}

// The oracle's arm seen from above, in W: base, shoulder, elbow, wrist (the paper's a4 = 0:
// the tool is over the wrist), by the closed form, not through the workcell's code.
inline std::array<P, 4> oracle_arm(const BasePose& b, const JointVector& q) {
  const double a1 = 0.067, a2 = 0.092, a3 = 0.095;
  const std::array<P, 4> local = {P{0.0, 0.0}, P{a1, 0.0},
                                  P{a1 + a2 * std::cos(q[1]), a2 * std::sin(q[1])},
                                  P{a1 + a2 * std::cos(q[1]) + a3 * std::cos(q[1] + q[2]),
                                    a2 * std::sin(q[1]) + a3 * std::sin(q[1] + q[2])}};
  std::array<P, 4> out{};
  const double c = std::cos(b.yaw_rad), s = std::sin(b.yaw_rad);
  for (int i = 0; i < 4; ++i) {
    out[i] = {b.x_m + c * local[i][0] - s * local[i][1], b.y_m + s * local[i][0] + c * local[i][1]};
  }
  return out;
}

// The tool (x, y, z) in W: over the wrist, z = d1 - 0.067 m above the base.
inline std::array<double, 3> oracle_tool(const BasePose& b, const JointVector& q) {
  const P w = oracle_arm(b, q)[3];
  return {w[0], w[1], b.z_m + q[0] - 0.067};
}

// Closest points of two segments by the clamped parameters (Ericson, Real-Time Collision
// Detection, 5.1.9): another method than the workcell's crossing test and end-point distances.
inline double segment_distance(P p1, P q1, P p2, P q2) {
  const P d1{q1[0] - p1[0], q1[1] - p1[1]}, d2{q2[0] - p2[0], q2[1] - p2[1]};
  const P r{p1[0] - p2[0], p1[1] - p2[1]};
  const double a = d1[0] * d1[0] + d1[1] * d1[1], e = d2[0] * d2[0] + d2[1] * d2[1];
  const double f = d2[0] * r[0] + d2[1] * r[1];
  double s = 0.0, t = 0.0;
  if (a <= 1e-18 && e <= 1e-18) {
    s = t = 0.0;
  } else if (a <= 1e-18) {
    t = std::clamp(f / e, 0.0, 1.0);
  } else {
    const double c = d1[0] * r[0] + d1[1] * r[1];
    if (e <= 1e-18) {
      s = std::clamp(-c / a, 0.0, 1.0);
    } else {
      const double b = d1[0] * d2[0] + d1[1] * d2[1], denom = a * e - b * b;
      s = denom > 1e-18 ? std::clamp((b * f - c * e) / denom, 0.0, 1.0) : 0.0;
      t = (b * s + f) / e;
      if (t < 0.0) {
        t = 0.0;
        s = std::clamp(-c / a, 0.0, 1.0);
      } else if (t > 1.0) {
        t = 1.0;
        s = std::clamp((b - c) / a, 0.0, 1.0);
      }
    }
  }
  const P c1{p1[0] + d1[0] * s, p1[1] + d1[1] * s}, c2{p2[0] + d2[0] * t, p2[1] + d2[1] * t};
  return std::hypot(c1[0] - c2[0], c1[1] - c2[1]);
}
inline double oracle_distance(const Workcell& w, const JointVector& qa, const JointVector& qb) {
  const auto a = oracle_arm(w.robots[0].base, qa);
  const auto b = oracle_arm(w.robots[1].base, qb);
  double d = INFINITY;
  for (int i = 0; i < 3; ++i) {
    for (int k = 0; k < 3; ++k) d = std::min(d, segment_distance(a[i], a[i + 1], b[k], b[k + 1]));
  }
  return d;
}

}  // namespace scaratwin::test
