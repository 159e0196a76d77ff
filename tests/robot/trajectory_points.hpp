// Trajectory points for the tests of the emulated robot, loaded as the hub loads them: a
// quintic from the home pose planned with scaratwin's planner and converted to motor steps,
// and the credit-based loading of docs/protocol.md section 9.
#pragma once

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "robot_harness.hpp"
#include "scaratwin/config/robot_config.hpp"
#include "scaratwin/kinematics/motor.hpp"
#include "scaratwin/trajectory/trajectory.hpp"

namespace scaratwin::test {

struct Point {
  int dt_ms;
  std::array<std::int32_t, 3> steps;
  int wrist_cdeg;
};

// A quintic from the home pose to `goal`, as the hub would load it: 60 samples (the first, the
// start, is not sent), absolute motor steps, dt in whole ms.
inline std::vector<Point> plan_points(const JointVector& goal, double duration_s,
                                      int samples = 60) {
  auto model = load_robot_config_or_default("");
  EXPECT_TRUE(model.ok());
  QuinticOptions o;
  o.samples = samples;
  o.duration_s = duration_s;
  auto traj = plan_quintic(*model, model->home, goal, o);
  if (!traj.ok()) {
    ADD_FAILURE() << traj.error().message;
    return {};
  }
  std::vector<Point> pts;
  long prev_ms = 0;
  for (std::size_t k = 1; k < traj->samples.size(); ++k) {
    const auto& s = traj->samples[k];
    const long t_ms = std::lround(s.t_s * 1000.0);
    pts.push_back({static_cast<int>(t_ms - prev_ms), joints_to_steps(*model, s.q),
                   static_cast<int>(std::lround(s.q[3] * 18000.0 / M_PI))});
    prev_ms = t_ms;
  }
  return pts;
}

inline std::string tp(int seq, const Point& p) {
  return "TP=" + std::to_string(seq) + "=" + std::to_string(p.dt_ms) + "=" +
         std::to_string(p.steps[0]) + "=" + std::to_string(p.steps[1]) + "=" +
         std::to_string(p.steps[2]) + "=" + std::to_string(p.wrist_cdeg) + "=\n";
}

// Sends points [first, last) of `pts` (their seq is their index) with credit-based flow
// control, as the hub does: the credit is the free queue slots of the latest AK=TP or ST
// report, minus the points sent since; one TP line is in flight at a time, which keeps within
// the 64-byte receive window. `credit` is the last reported free count (AK=TB's). Events that
// arrive meanwhile are appended to *events when given. Fails on any refusal.
inline bool stream_points(Robot& r, const std::vector<Point>& pts, std::size_t first,
                          std::size_t last, int credit,
                          const std::function<void()>& on_progress = {},
                          std::vector<std::string>* events = nullptr) {
  bool in_flight = false;
  std::size_t ok = first;
  std::size_t next = first;
  while (ok < last) {
    if (on_progress) on_progress();
    if (!in_flight && next < last && credit > 0) {
      r.send(tp(static_cast<int>(next), pts[next]));
      ++next;
      in_flight = true;
    }
    auto l = r.line(30.0, true);
    if (!l) {
      ADD_FAILURE() << "no reply while loading point " << ok;
      return false;
    }
    if (auto st = parse_report(*l)) {
      if (!in_flight) credit = static_cast<int>(st->queue_free());
    } else if (l->rfind("AK=TP=", 0) == 0) {
      ++ok;
      in_flight = false;
      credit = std::atoi(l->c_str() + 6);
    } else if (l->rfind("EV=", 0) == 0) {
      if (events) events->push_back(*l);  // underrun or other events while streaming
    } else {
      ADD_FAILURE() << "point " << ok << " refused: " << *l;
      return false;
    }
  }
  return true;
}

// Loads a whole trajectory (TB, then every point with stream_points).
inline bool load_trajectory(Robot& r, const std::vector<Point>& pts, int* acks = nullptr,
                            const std::function<void()>& on_progress = {}) {
  auto tb = r.request("TB=" + std::to_string(pts.size()) + "=\n");
  if (!tb || tb->rfind("AK=TB=", 0) != 0) {
    ADD_FAILURE() << "TB refused: " << tb.value_or("timeout");
    return false;
  }
  if (!stream_points(r, pts, 0, pts.size(), std::atoi(tb->c_str() + 6), on_progress)) {
    return false;
  }
  if (acks) *acks = static_cast<int>(pts.size());
  return true;
}

// The robot at rest (two reports 50 ms of emulated time apart agree and the moving flag is
// clear), its truth at the given steps.
inline void expect_at_rest_at(Robot& r, const std::array<std::int32_t, 3>& steps) {
  std::optional<Report> st;
  for (int i = 0; i < 400; ++i) {
    st = r.query_state();
    ASSERT_TRUE(st);
    if ((st->flags() & 2) == 0) break;
  }
  EXPECT_EQ(st->flags() & 2, 0) << "still moving";
  const Truth t = r.truth();
  EXPECT_EQ(t.i("z"), steps[0]);
  EXPECT_EQ(t.i("j2"), steps[1]);
  EXPECT_EQ(t.i("j3"), steps[2]);
}

}  // namespace scaratwin::test
