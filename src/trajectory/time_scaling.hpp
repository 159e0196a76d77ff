// Internal: a trapezoidal time scaling s(t) from 0 to 1, shared by the joint-space trapezoid
// and the Cartesian line.
#pragma once

#include <cmath>

namespace scaratwin::detail {

// s(t) with peak speed at most v (1/s) and acceleration a (1/s^2): a triangle when the
// speed limit is never reached.
struct TrapezoidScaling {
  double a = 0.0;
  double vp = 0.0;
  double ta = 0.0;
  double total_s = 0.0;

  static TrapezoidScaling make(double v, double acc) {
    TrapezoidScaling p;
    p.a = acc;
    if (v * v / acc >= 1.0) {
      p.ta = std::sqrt(1.0 / acc);
      p.total_s = 2.0 * p.ta;
      p.vp = acc * p.ta;
    } else {
      p.ta = v / acc;
      p.total_s = p.ta + 1.0 / v;
      p.vp = v;
    }
    return p;
  }

  void eval(double t, double& s, double& sd, double& sdd) const {
    if (t >= total_s) {
      s = 1.0;
      sd = 0.0;
      sdd = -a;
    } else if (t < ta) {
      s = 0.5 * a * t * t;
      sd = a * t;
      sdd = a;
    } else if (t <= total_s - ta) {
      s = 0.5 * a * ta * ta + vp * (t - ta);
      sd = vp;
      sdd = 0.0;
    } else {
      const double r = total_s - t;
      s = 1.0 - 0.5 * a * r * r;
      sd = a * r;
      sdd = -a;
    }
  }

  // Sample times: every dt plus the end.
  int intervals(double dt) const { return static_cast<int>(std::ceil(total_s / dt - 1e-9)); }
};

}  // namespace scaratwin::detail
