// Trajectories for Python: the planners of scaratwin/trajectory (quintic, trapezoid, via
// points, Cartesian line, pick-and-place) return a Trajectory whose t, q, qd and qdd are numpy
// views of the C++ samples (no per-element copy; read-only, kept alive by the Trajectory).
#include <cmath>
#include <cstddef>

#include <fmt/format.h>
#include <pybind11/stl.h>

#include "common.hpp"
#include "scaratwin/trajectory/trajectory.hpp"

namespace scaratwin::python {
namespace {

static_assert(sizeof(JointSample) == 13 * sizeof(double), "JointSample must be 13 packed doubles");
static_assert(offsetof(JointSample, q) == sizeof(double));
static_assert(offsetof(JointSample, qd) == 5 * sizeof(double));
static_assert(offsetof(JointSample, qdd) == 9 * sizeof(double));

constexpr py::ssize_t kStride = sizeof(JointSample);

struct Trajectory {
  JointTrajectory traj;
};
using TrajectoryPtr = std::shared_ptr<Trajectory>;

// A read-only view of the samples: one column (t) or four (q, qd, qdd) at `offset`.
py::array view(const py::object& self, std::size_t offset, bool vector) {
  Trajectory& t = self.cast<Trajectory&>();
  const auto n = static_cast<py::ssize_t>(t.traj.samples.size());
  auto* base = reinterpret_cast<char*>(t.traj.samples.data()) + offset;
  py::array a = vector ? py::array(py::dtype::of<double>(), {n, py::ssize_t{4}},
                                   {kStride, static_cast<py::ssize_t>(sizeof(double))}, base, self)
                       : py::array(py::dtype::of<double>(), {n}, {kStride}, base, self);
  a.attr("flags").attr("writeable") = false;
  return a;
}

JointVector one_row(const py::object& obj, const char* call, const char* what) {
  const Rows r = rows_of(obj, call, what);
  if (!r.single) throw py::value_error(fmt::format("{}: {} must have shape (4,)", call, what));
  require_finite(r, call, what);
  return {r.ptr()[0], r.ptr()[1], r.ptr()[2], r.ptr()[3]};
}

ToolPose one_pose(const py::object& obj, const char* call, const char* what) {
  const JointVector v = one_row(obj, call, what);
  return {v[0], v[1], v[2], v[3]};
}

TrajectoryPtr wrap(Result<JointTrajectory> r) {
  if (!r) raise(ErrorKind::kPlan, r.error());
  return std::make_shared<Trajectory>(Trajectory{std::move(*r)});
}

// A Trajectory from arrays (t, q and optionally qd, qdd; gripper events).
TrajectoryPtr from_arrays(const py::object& t, const py::object& q, const py::object& qd,
                          const py::object& qdd, const py::object& events) {
  auto ta = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(t);
  if (!ta || ta.ndim() != 1)
    throw py::value_error("Trajectory: t must be a 1-D array of times (s)");
  const Rows qr = rows_of(q, "Trajectory", "q");
  if (qr.single || qr.n != ta.size()) {
    throw py::value_error(
        fmt::format("Trajectory: q must have shape ({}, 4) (one row per time)", ta.size()));
  }
  require_finite(qr, "Trajectory", "q");
  auto opt_rows = [&](const py::object& o, const char* what) -> Rows {
    if (o.is_none()) return {};
    Rows r = rows_of(o, "Trajectory", what);
    if (r.single || r.n != ta.size()) {
      throw py::value_error(fmt::format("Trajectory: {} must have shape ({}, 4)", what, ta.size()));
    }
    return r;
  };
  const Rows qdr = opt_rows(qd, "qd");
  const Rows qddr = opt_rows(qdd, "qdd");
  auto tr = std::make_shared<Trajectory>();
  const double* tv = ta.data();
  for (py::ssize_t i = 0; i < ta.size(); ++i) {
    if (!std::isfinite(tv[i]) || (i == 0 && tv[i] != 0.0) || (i > 0 && tv[i] <= tv[i - 1])) {
      throw py::value_error(fmt::format(
          "Trajectory: t[{}] = {}: times must start at 0 and strictly increase", i, tv[i]));
    }
    JointSample s;
    s.t_s = tv[i];
    for (int j = 0; j < 4; ++j) {
      s.q[j] = qr.ptr()[4 * i + j];
      s.qd[j] = qdr.ptr() ? qdr.ptr()[4 * i + j] : 0.0;
      s.qdd[j] = qddr.ptr() ? qddr.ptr()[4 * i + j] : 0.0;
    }
    tr->traj.samples.push_back(s);
  }
  for (const py::handle e : events) {
    const auto pair = e.cast<std::pair<double, std::string>>();
    GripperEvent ev;
    ev.t_s = pair.first;
    if (pair.second == "grip") {
      ev.action = GripperAction::kGrip;
    } else if (pair.second == "release") {
      ev.action = GripperAction::kRelease;
    } else {
      throw py::value_error(
          fmt::format("Trajectory: event action '{}': expected 'grip' or 'release'", pair.second));
    }
    tr->traj.events.push_back(ev);
  }
  return tr;
}

}  // namespace

const JointTrajectory& trajectory_of(const py::handle& obj) { return obj.cast<Trajectory&>().traj; }

void bind_trajectory(py::module_& m) {
  py::class_<Trajectory, TrajectoryPtr>(
      m, "Trajectory",
      "A timed joint trajectory: t (N,) s, q (N, 4) m/rad, qd (N, 4) per s, qdd (N, 4) per "
      "s^2, and gripper events. The arrays are read-only views of the C++ samples.")
      .def(py::init(&from_arrays), py::arg("t"), py::arg("q"), py::arg("qd") = py::none(),
           py::arg("qdd") = py::none(), py::arg("events") = py::list(),
           "A trajectory from arrays: t starts at 0 and strictly increases; events is a list "
           "of (t_s, 'grip' | 'release').")
      .def_property_readonly(
          "t", [](const py::object& self) { return view(self, offsetof(JointSample, t_s), false); },
          "Sample times (s), shape (N,).")
      .def_property_readonly(
          "q", [](const py::object& self) { return view(self, offsetof(JointSample, q), true); },
          "Positions (d1_m, q2_rad, q3_rad, q4_rad), shape (N, 4).")
      .def_property_readonly(
          "qd", [](const py::object& self) { return view(self, offsetof(JointSample, qd), true); },
          "Velocities (m/s, rad/s), shape (N, 4).")
      .def_property_readonly(
          "qdd",
          [](const py::object& self) { return view(self, offsetof(JointSample, qdd), true); },
          "Accelerations (m/s^2, rad/s^2), shape (N, 4).")
      .def_property_readonly(
          "events",
          [](const Trajectory& t) {
            py::list l;
            for (const GripperEvent& e : t.traj.events) {
              l.append(
                  py::make_tuple(e.t_s, e.action == GripperAction::kGrip ? "grip" : "release"));
            }
            return l;
          },
          "Gripper events: a list of (t_s, 'grip' | 'release'), sorted by time.")
      .def_property_readonly(
          "duration_s", [](const Trajectory& t) { return t.traj.duration_s(); },
          "Time of the last sample (s).")
      .def("__len__", [](const Trajectory& t) { return t.traj.samples.size(); })
      .def(
          "sample_at",
          [](const Trajectory& t, double t_s) {
            const JointVector q = sample_at(t.traj, t_s);
            py::array_t<double> a(4);
            for (int j = 0; j < 4; ++j) a.mutable_at(j) = q[j];
            return a;
          },
          py::arg("t_s"), "Position at time t_s (linear between samples, clamped to the ends).")
      .def(
          "check_limits",
          [](const Trajectory& t, const py::object& robot, double tolerance) {
            const RobotPtr r = robot_or_default(robot);
            check(check_limits(r->model, t.traj, tolerance), ErrorKind::kPlan);
          },
          py::arg("robot") = py::none(), py::arg("tolerance") = 1e-6,
          "Raises PlanError naming the sample, joint or motor when a joint, speed or "
          "acceleration limit is exceeded.")
      .def("__repr__", [](const Trajectory& t) {
        return fmt::format("<scaratwin.Trajectory {} samples, {:.3f} s, {} gripper events>",
                           t.traj.samples.size(), t.traj.duration_s(), t.traj.events.size());
      });

  m.def(
      "quintic",
      [](const py::object& q0, const py::object& q1, double duration_s, int samples) {
        const JointVector a = one_row(q0, "quintic", "q0");
        const JointVector b = one_row(q1, "quintic", "q1");
        if (samples < 2 || !(duration_s > 0.0)) {
          throw py::value_error(fmt::format(
              "quintic: samples = {}, duration_s = {}: need samples >= 2 and duration_s > 0",
              samples, duration_s));
        }
        return std::make_shared<Trajectory>(Trajectory{quintic(a, b, duration_s, samples)});
      },
      py::arg("q0"), py::arg("q1"), py::arg("duration_s"), py::arg("samples") = 60,
      "The paper's jtraj: a fifth-order polynomial from q0 to q1 (zero velocity and "
      "acceleration at both ends), `samples` samples over duration_s. No limit check.");
  m.def(
      "plan_quintic",
      [](const py::object& q0, const py::object& q1, double duration_s, int samples,
         const py::object& robot) {
        const RobotPtr r = robot_or_default(robot);
        return wrap(plan_quintic(r->model, one_row(q0, "plan_quintic", "q0"),
                                 one_row(q1, "plan_quintic", "q1"), {samples, duration_s}));
      },
      py::arg("q0"), py::arg("q1"), py::arg("duration_s") = 0.0, py::arg("samples") = 60,
      py::arg("robot") = py::none(),
      "A quintic inside every joint and motor limit (duration_s = 0: the shortest that honours "
      "the motor limits). Raises PlanError.");
  m.def(
      "plan_trapezoid",
      [](const py::object& q0, const py::object& q1, double dt_s, double speed_scale,
         double accel_scale, const py::object& robot) {
        const RobotPtr r = robot_or_default(robot);
        return wrap(plan_trapezoid(r->model, one_row(q0, "plan_trapezoid", "q0"),
                                   one_row(q1, "plan_trapezoid", "q1"),
                                   {dt_s, speed_scale, accel_scale}));
      },
      py::arg("q0"), py::arg("q1"), py::arg("dt_s") = 0.01, py::arg("speed_scale") = 1.0,
      py::arg("accel_scale") = 1.0, py::arg("robot") = py::none(),
      "Synchronised trapezoidal motion (all motors start and arrive together), sampled every "
      "dt_s. Raises PlanError.");
  m.def(
      "plan_via_points",
      [](const py::object& points, const std::string& profile, double dt_s, double speed_scale,
         double accel_scale, int quintic_samples, const py::object& robot) {
        const RobotPtr r = robot_or_default(robot);
        const Rows pr = rows_of(points, "plan_via_points", "points");
        require_finite(pr, "plan_via_points", "points");
        if (profile != "quintic" && profile != "trapezoid") {
          throw py::value_error(fmt::format(
              "plan_via_points: profile '{}': expected 'quintic' or 'trapezoid'", profile));
        }
        std::vector<JointVector> pts;
        for (py::ssize_t i = 0; i < pr.n; ++i) {
          const double* p = pr.ptr() + 4 * i;
          pts.push_back({p[0], p[1], p[2], p[3]});
        }
        ViaOptions o;
        o.profile = profile == "quintic" ? Profile::kQuintic : Profile::kTrapezoid;
        o.trapezoid = {dt_s, speed_scale, accel_scale};
        o.quintic_samples = quintic_samples;
        return wrap(plan_via_points(r->model, pts, o));
      },
      py::arg("points"), py::arg("profile") = "trapezoid", py::arg("dt_s") = 0.01,
      py::arg("speed_scale") = 1.0, py::arg("accel_scale") = 1.0, py::arg("quintic_samples") = 60,
      py::arg("robot") = py::none(),
      "Through joint points (K, 4), stopping at each (points[0] is the start).");
  m.def(
      "plan_line",
      [](const py::object& q0, const py::object& goal, double max_step_m, double dt_s,
         double speed_scale, double accel_scale, const py::object& robot) {
        const RobotPtr r = robot_or_default(robot);
        return wrap(plan_line(r->model, one_row(q0, "plan_line", "q0"),
                              one_pose(goal, "plan_line", "goal"),
                              {max_step_m, dt_s, speed_scale, accel_scale}));
      },
      py::arg("q0"), py::arg("goal"), py::arg("max_step_m") = 0.001, py::arg("dt_s") = 0.01,
      py::arg("speed_scale") = 1.0, py::arg("accel_scale") = 1.0, py::arg("robot") = py::none(),
      "Straight tool line from the pose at q0 to goal (x_m, y_m, z_m, yaw_rad), IK at every "
      "max_step_m, timed within the motor limits. Raises PlanError.");
  m.def(
      "plan_pick_place",
      [](const py::object& q0, const py::object& pick, const py::object& place,
         const py::object& approach_height_m, double grip_dwell_s, double speed_scale,
         double accel_scale, double dt_s, const py::object& robot) {
        const RobotPtr r = robot_or_default(robot);
        PickPlaceRequest req;
        req.pick = one_pose(pick, "plan_pick_place", "pick");
        req.place = one_pose(place, "plan_pick_place", "place");
        req.approach_height_m = approach_height_m.is_none() ? r->model.scene.approach_height_m
                                                            : approach_height_m.cast<double>();
        req.grip_dwell_s = grip_dwell_s;
        req.speed_scale = speed_scale;
        req.accel_scale = accel_scale;
        req.dt_s = dt_s;
        return wrap(plan_pick_place(r->model, one_row(q0, "plan_pick_place", "q0"), req));
      },
      py::arg("q0"), py::arg("pick"), py::arg("place"), py::arg("approach_height_m") = py::none(),
      py::arg("grip_dwell_s") = 0.4, py::arg("speed_scale") = 1.0, py::arg("accel_scale") = 1.0,
      py::arg("dt_s") = 0.01, py::arg("robot") = py::none(),
      "Pick and place: approach, descend, grip, lift, travel, descend, release, retreat; one "
      "trajectory with the gripper events. Poses are (x_m, y_m, z_m, yaw_rad); the approach "
      "height defaults to the description's scene.approach_height_m.");
}

}  // namespace scaratwin::python
