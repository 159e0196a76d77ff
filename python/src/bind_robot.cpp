// The robot description and its kinematics for Python: load and inspect a description, FK/IK
// single and batched, the Jacobian, joint <-> motor step conversions. Batched calls loop in C++
// with the GIL released and write straight into the numpy arrays they return.
#include <cmath>
#include <limits>
#include <string_view>

#include <fmt/format.h>
#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>

#include "common.hpp"
#include "scaratwin/config/robot_config.hpp"
#include "scaratwin/kinematics/kinematics.hpp"
#include "scaratwin/kinematics/motor.hpp"
#include "scaratwin/kinematics/physical.hpp"

namespace scaratwin::python {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

JointVector row(const double* p) { return {p[0], p[1], p[2], p[3]}; }

// The description's as-built key (a2_mm, j2_zero_deg, z_lead_percent) with its SI unit.
std::string si_key(std::string_view key) {
  const auto ends = [&](std::string_view s) {
    return key.size() > s.size() && key.substr(key.size() - s.size()) == s;
  };
  const auto stem = [&](std::size_t n) { return std::string(key.substr(0, key.size() - n)); };
  if (ends("_mm")) return stem(3) + "_m";
  if (ends("_deg")) return stem(4) + "_rad";
  if (ends("_percent")) return stem(8) + "_fraction";
  return std::string(key);
}

py::dict stepper_dict(const StepperAxis& a) {
  py::dict d;
  d["steps_per_unit"] = a.steps_per_unit;
  d["max_speed_steps_s"] = a.max_speed_steps_s;
  d["max_accel_steps_s2"] = a.max_accel_steps_s2;
  return d;
}

py::dict servo_dict(const ServoSpec& s) {
  py::dict d;
  d["min_deg"] = s.min_deg;
  d["max_deg"] = s.max_deg;
  d["pulse_min_us"] = s.pulse_min_us;
  d["pulse_max_us"] = s.pulse_max_us;
  d["max_speed_deg_s"] = s.max_speed_deg_s;
  return d;
}

py::array structured(const py::list& rows, const py::list& dtype) {
  return py::module_::import("numpy").attr("array")(rows, py::arg("dtype") = dtype);
}

py::array dh_table(const RobotModel& m) {
  py::list rows;
  for (int i = 0; i < kNumJoints; ++i) {
    const DhRow& r = m.dh[i];
    rows.append(py::make_tuple(joint_name(i),
                               r.type == JointType::kPrismatic ? "prismatic" : "revolute",
                               r.theta_rad, r.d_m, r.a_m, r.alpha_rad));
  }
  py::list dtype;
  dtype.append(py::make_tuple("joint", "U2"));
  dtype.append(py::make_tuple("type", "U9"));
  for (const char* f : {"theta_rad", "d_m", "a_m", "alpha_rad"}) {
    dtype.append(py::make_tuple(f, "f8"));
  }
  return structured(rows, dtype);
}

py::dict as_built_dict(const AsBuiltProfile& p) {
  py::dict tol, fixed;
  const auto& keys = as_built_keys();
  for (int i = 0; i < kAsBuiltCount; ++i) {
    tol[py::str(si_key(keys[i].key))] = p.tolerance[i];
    if (p.fixed[i]) fixed[py::str(si_key(keys[i].key))] = p.value[i];
  }
  py::dict d;
  d["seed"] = p.seed;
  d["tolerance"] = tol;
  d["values"] = fixed;
  return d;
}

// ---- kinematics --------------------------------------------------------------------------

py::object fk(const py::object& joints, const py::object& robot) {
  const RobotPtr r = robot_or_default(robot);
  const Rows in = rows_of(joints, "fk", "joints");
  py::array_t<double> out = new_rows(in.n, in.single);
  double* o = out.mutable_data();
  {
    py::gil_scoped_release nogil;
    for (py::ssize_t i = 0; i < in.n; ++i) {
      const ToolPose p = forward(r->model, row(in.ptr() + 4 * i));
      o[4 * i] = p.x_m;
      o[4 * i + 1] = p.y_m;
      o[4 * i + 2] = p.z_m;
      o[4 * i + 3] = p.yaw_rad;
    }
  }
  return out;
}

py::tuple ik(const py::object& poses, const py::object& seed, const py::object& robot) {
  const RobotPtr r = robot_or_default(robot);
  const Rows in = rows_of(poses, "ik", "poses");
  require_finite(in, "ik", "poses");
  Rows seeds;
  bool one_seed = true;
  JointVector fixed_seed = r->model.home;
  if (!seed.is_none()) {
    seeds = rows_of(seed, "ik", "seed");
    require_finite(seeds, "ik", "seed");
    if (seeds.single) {
      fixed_seed = row(seeds.ptr());
    } else if (seeds.n == in.n && !in.single) {
      one_seed = false;
    } else {
      throw py::value_error(
          fmt::format("ik: seed must have shape (4,) or the shape of poses ({}, 4), got ({}, 4)",
                      in.n, seeds.n));
    }
  }
  py::array_t<double> out = new_rows(in.n, in.single);
  py::array_t<std::int32_t> status(in.n);
  double* o = out.mutable_data();
  std::int32_t* st = status.mutable_data();
  {
    py::gil_scoped_release nogil;
    for (py::ssize_t i = 0; i < in.n; ++i) {
      const double* p = in.ptr() + 4 * i;
      const JointVector s = one_seed ? fixed_seed : row(seeds.ptr() + 4 * i);
      auto q = inverse(r->model, {p[0], p[1], p[2], p[3]}, s);
      double* qo = o + 4 * i;
      if (q) {
        qo[0] = (*q)[0];
        qo[1] = (*q)[1];
        qo[2] = (*q)[2];
        qo[3] = (*q)[3];
        st[i] = 0;
      } else {
        qo[0] = qo[1] = qo[2] = qo[3] = kNaN;
        st[i] = q.error().code;
      }
    }
  }
  if (in.single) return py::make_tuple(std::move(out), py::int_(st[0]));
  return py::make_tuple(std::move(out), std::move(status));
}

py::array ik_all(const py::object& pose, const py::object& seed, const py::object& robot) {
  const RobotPtr r = robot_or_default(robot);
  const Rows in = rows_of(pose, "ik_all", "pose");
  if (!in.single) throw py::value_error("ik_all: pose must have shape (4,) (one pose)");
  require_finite(in, "ik_all", "pose");
  JointVector s = r->model.home;
  if (!seed.is_none()) {
    const Rows sr = rows_of(seed, "ik_all", "seed");
    if (!sr.single) throw py::value_error("ik_all: seed must have shape (4,)");
    require_finite(sr, "ik_all", "seed");
    s = row(sr.ptr());
  }
  auto sol = inverse_all(r->model, {in.ptr()[0], in.ptr()[1], in.ptr()[2], in.ptr()[3]}, s);
  if (!sol) {
    raise(ErrorKind::kUnreachable, Error{sol.error().code, "unreachable: " + sol.error().message});
  }
  py::array_t<double> out({static_cast<py::ssize_t>(sol->count), py::ssize_t{4}});
  for (int i = 0; i < sol->count; ++i) {
    for (int j = 0; j < 4; ++j) out.mutable_at(i, j) = sol->solutions[i][j];
  }
  return out;
}

py::object jacobian(const py::object& joints, const py::object& robot) {
  const RobotPtr r = robot_or_default(robot);
  const Rows in = rows_of(joints, "jacobian", "joints");
  py::array_t<double> out = in.single ? py::array_t<double>({4, 4})
                                      : py::array_t<double>({in.n, py::ssize_t{4}, py::ssize_t{4}});
  double* o = out.mutable_data();
  {
    py::gil_scoped_release nogil;
    for (py::ssize_t i = 0; i < in.n; ++i) {
      const Eigen::Matrix4d J = jacobian(r->model, row(in.ptr() + 4 * i));
      for (int a = 0; a < 4; ++a) {
        for (int b = 0; b < 4; ++b) o[16 * i + 4 * a + b] = J(a, b);
      }
    }
  }
  return out;
}

py::object outside_limits(const py::object& joints, const py::object& robot) {
  const RobotPtr r = robot_or_default(robot);
  const Rows in = rows_of(joints, "outside_limits", "joints");
  py::array_t<std::int32_t> out(in.n);
  std::int32_t* o = out.mutable_data();
  for (py::ssize_t i = 0; i < in.n; ++i) {
    o[i] = first_joint_outside_limits(r->model, row(in.ptr() + 4 * i));
  }
  if (in.single) return py::int_(o[0]);
  return out;
}

py::tuple joints_to_motors_py(const py::object& joints, const py::object& robot) {
  const RobotPtr r = robot_or_default(robot);
  const Rows in = rows_of(joints, "joints_to_motors", "joints");
  py::array_t<double> steps = new_rows(in.n, in.single, 3);
  py::array_t<double> wrist(in.n);
  double* s = steps.mutable_data();
  double* w = wrist.mutable_data();
  for (py::ssize_t i = 0; i < in.n; ++i) {
    const MotorPosition m = joints_to_motors(r->model, row(in.ptr() + 4 * i));
    for (int k = 0; k < 3; ++k) s[3 * i + k] = m.steps[k];
    w[i] = m.wrist_deg;
  }
  if (in.single) return py::make_tuple(std::move(steps), py::float_(w[0]));
  return py::make_tuple(std::move(steps), std::move(wrist));
}

py::array joints_to_steps_py(const py::object& joints, const py::object& robot) {
  const RobotPtr r = robot_or_default(robot);
  const Rows in = rows_of(joints, "joints_to_steps", "joints");
  require_finite(in, "joints_to_steps", "joints");
  py::array_t<std::int32_t> out =
      in.single ? py::array_t<std::int32_t>(3) : py::array_t<std::int32_t>({in.n, py::ssize_t{3}});
  std::int32_t* o = out.mutable_data();
  for (py::ssize_t i = 0; i < in.n; ++i) {
    const auto s = joints_to_steps(r->model, row(in.ptr() + 4 * i));
    for (int k = 0; k < 3; ++k) o[3 * i + k] = s[k];
  }
  return out;
}

py::array motors_to_joints_py(const py::object& steps, const py::object& wrist_deg,
                              const py::object& robot) {
  const RobotPtr r = robot_or_default(robot);
  const Rows in = rows_of(steps, "motors_to_joints", "steps", 3);
  py::array_t<double, py::array::c_style | py::array::forcecast> w =
      py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(wrist_deg);
  if (!w) throw py::type_error("motors_to_joints: wrist_deg must be a number or an array");
  if (w.size() != 1 && w.size() != in.n) {
    throw py::value_error(
        fmt::format("motors_to_joints: wrist_deg must be one value or one per row ({}), got {}",
                    in.n, w.size()));
  }
  py::array_t<double> out = new_rows(in.n, in.single);
  double* o = out.mutable_data();
  for (py::ssize_t i = 0; i < in.n; ++i) {
    const double* s = in.ptr() + 3 * i;
    const JointVector q =
        motors_to_joints(r->model, {s[0], s[1], s[2]}, w.data()[w.size() == 1 ? 0 : i]);
    for (int k = 0; k < 4; ++k) o[4 * i + k] = q[k];
  }
  return out;
}

// A joint map applied row by row (firmware_to_joints, joints_to_firmware).
py::object map_rows(const py::object& joints, const py::object& robot, const char* call,
                    JointVector (*f)(const RobotModel&, const JointVector&)) {
  const RobotPtr r = robot_or_default(robot);
  const Rows in = rows_of(joints, call, "joints");
  py::array_t<double> out = new_rows(in.n, in.single);
  double* o = out.mutable_data();
  for (py::ssize_t i = 0; i < in.n; ++i) {
    const JointVector q = f(r->model, row(in.ptr() + 4 * i));
    for (int k = 0; k < 4; ++k) o[4 * i + k] = q[k];
  }
  return out;
}

RobotPtr load(const py::object& path) {
  if (path.is_none()) {
    return py::module_::import("scaratwin").attr("default_robot")().cast<RobotPtr>();
  }
  const std::filesystem::path p = path.cast<std::filesystem::path>();
  auto m = load_robot_config(p);
  if (!m) raise(ErrorKind::kConfig, m.error());
  return std::make_shared<Robot>(Robot{std::move(*m), p.string()});
}

}  // namespace

void bind_robot(py::module_& m) {
  py::class_<Robot, RobotPtr>(m, "Robot",
                              "A robot description (config/scara.toml), loaded and validated "
                              "once. SI units: metres, radians, seconds.")
      .def_property_readonly(
          "name", [](const Robot& r) { return r.model.name; }, "The description's name.")
      .def_property_readonly(
          "path", [](const Robot& r) { return r.path; },
          "The file it was loaded from ('' for the built-in paper robot).")
      .def_property_readonly(
          "dh", [](const Robot& r) { return dh_table(r.model); },
          "The standard DH table: a structured array of 4 rows (joint, type, theta_rad, d_m, "
          "a_m, alpha_rad).")
      .def_property_readonly(
          "limits",
          [](const Robot& r) {
            py::array_t<double> a({4, 2});
            for (int i = 0; i < 4; ++i) {
              a.mutable_at(i, 0) = r.model.limits[i].min;
              a.mutable_at(i, 1) = r.model.limits[i].max;
            }
            return a;
          },
          "Joint travel, shape (4, 2): [min, max] of d1 (m), q2, q3, q4 (rad).")
      .def_property_readonly(
          "home",
          [](const Robot& r) {
            py::array_t<double> a(4);
            for (int i = 0; i < 4; ++i) a.mutable_at(i) = r.model.home[i];
            return a;
          },
          "Home joints (d1_m, q2_rad, q3_rad, q4_rad).")
      .def_property_readonly(
          "motors",
          [](const Robot& r) {
            const MotorModel& mm = r.model.motors;
            py::dict d;
            d["z"] = stepper_dict(mm.z);
            d["j2"] = stepper_dict(mm.j2);
            d["j3"] = stepper_dict(mm.j3);
            d["j3_per_j2_coupling"] = mm.j3_per_j2_coupling;
            d["wrist"] = servo_dict(mm.wrist);
            d["gripper"] = servo_dict(mm.gripper);
            d["gripper_open_deg"] = mm.gripper_open_deg;
            d["gripper_closed_deg"] = mm.gripper_closed_deg;
            return d;
          },
          "Motor conversions: steppers z (steps/m), j2, j3 (steps/rad) with speed and "
          "acceleration limits (steps/s, steps/s^2), the J2->J3 belt coupling, the servos.")
      .def_property_readonly(
          "endstops",
          [](const Robot& r) {
            const EndstopModel& e = r.model.endstops;
            py::dict d;
            d["closes_at"] = std::vector<double>(e.closes_at.begin(), e.closes_at.end());
            d["homing_dir"] = std::vector<int>(e.homing_dir.begin(), e.homing_dir.end());
            d["pulloff_steps"] = e.pulloff_steps;
            return d;
          },
          "Endstop switches of Z, J2, J3: where each closes (m, rad), the homing direction, "
          "the pull-off (steps).")
      .def_property_readonly(
          "scene",
          [](const Robot& r) {
            const SceneModel& s = r.model.scene;
            py::dict trays;
            for (int c = 0; c < kNumColors; ++c) {
              py::dict t;
              t["x_m"] = s.trays[c].x_m;
              t["y_m"] = s.trays[c].y_m;
              t["size_m"] = s.trays[c].size_m;
              trays[color_name(static_cast<CubeColor>(c))] = t;
            }
            py::dict cam;
            cam["pos_m"] = std::vector<double>(s.camera.pos_m.begin(), s.camera.pos_m.end());
            cam["look_at_m"] =
                std::vector<double>(s.camera.look_at_m.begin(), s.camera.look_at_m.end());
            cam["fovy_deg"] = s.camera.fovy_deg;
            cam["width_px"] = s.camera.width_px;
            cam["height_px"] = s.camera.height_px;
            py::dict d;
            d["table_z_m"] = s.table_z_m;
            d["cube_size_m"] = s.cube_size_m;
            d["grasp_z_m"] = s.grasp_z_m;
            d["approach_height_m"] = s.approach_height_m;
            d["trays"] = trays;
            d["camera"] = cam;
            return d;
          },
          "The work scene in the base frame: table, cube size, grasp height, trays, camera.")
      .def_property_readonly(
          "as_built", [](const Robot& r) { return as_built_dict(r.model.physical.as_built); },
          "The [as_built] tolerance profile of the description (SI keys: a2_m, j2_zero_rad, "
          "z_lead_fraction, ...): seed, tolerance per parameter, explicit values.")
      .def_property_readonly(
          "calibrated",
          [](const Robot& r) {
            const JointCalibration& c = r.model.calibration;
            return r.model.webcam.valid || c.z_offset_m != 0.0 || c.z_scale != 0.0 ||
                   c.j2_zero_rad != 0.0 || c.j3_zero_rad != 0.0 || c.wrist_offset_rad != 0.0 ||
                   c.wrist_gain != 0.0 || c.backlash != std::array<double, 3>{};
          },
          "True for a calibration overlay (written by `scaratwin calibrate`) that identified "
          "anything; dh and the joint map then describe the robot as measured.")
      .def_property_readonly(
          "calibration",
          [](const Robot& r) {
            const JointCalibration& c = r.model.calibration;
            py::dict d;
            d["z_offset_m"] = c.z_offset_m;
            d["z_scale"] = c.z_scale;
            d["j2_zero_rad"] = c.j2_zero_rad;
            d["j3_zero_rad"] = c.j3_zero_rad;
            d["wrist_offset_rad"] = c.wrist_offset_rad;
            d["wrist_gain"] = c.wrist_gain;
            d["backlash"] = std::vector<double>(c.backlash.begin(), c.backlash.end());
            return d;
          },
          "The calibration's joint map from the firmware's joints to the true ones (all zero, "
          "the identity, until calibrated): z_offset_m, z_scale, j2_zero_rad, j3_zero_rad, "
          "wrist_offset_rad, wrist_gain, backlash (Z m, J2 rad, J3 rad).")
      .def_property_readonly(
          "webcam",
          [](const Robot& r) -> py::object {
            const WebcamCalibration& w = r.model.webcam;
            if (!w.valid) return py::none();
            py::dict d;
            d["pos_m"] = std::vector<double>(w.pos_m.begin(), w.pos_m.end());
            d["r_bc"] = std::vector<double>(w.r_bc.begin(), w.r_bc.end());
            d["f_px"] = w.f_px;
            d["cx_px"] = w.cx_px;
            d["cy_px"] = w.cy_px;
            d["k1"] = w.k1;
            d["k2"] = w.k2;
            d["width_px"] = w.width_px;
            d["height_px"] = w.height_px;
            return d;
          },
          "The physical webcam as calibrated (pinhole and radial distortion), None before.")
      .def(
          "draw_as_built",
          [](const Robot& r) {
            const AsBuilt b = draw_as_built(r.model.physical.as_built);
            py::dict d;
            const auto& keys = as_built_keys();
            for (int i = 0; i < kAsBuiltCount; ++i) d[py::str(si_key(keys[i].key))] = b.v[i];
            return d;
          },
          "The robot as built that the emulator draws from the profile (same seed, same robot "
          "on every machine): deviation per parameter, SI.")
      .def("__repr__", [](const Robot& r) {
        return fmt::format("<scaratwin.Robot '{}' from '{}'>", r.model.name,
                           r.path.empty() ? "(built in)" : r.path);
      });

  m.def("load_robot", &load, py::arg("path") = py::none(),
        "Loads and validates a robot description (TOML). None: the default description "
        "($SCARATWIN_CONFIG, else the installed config/scara.toml). Raises ConfigError naming "
        "the bad key.");
  m.def(
      "parse_robot",
      [](const std::string& text, const std::string& source) {
        auto r = parse_robot_config(text, source);
        if (!r) raise(ErrorKind::kConfig, r.error());
        return std::make_shared<Robot>(Robot{std::move(*r), ""});
      },
      py::arg("text"), py::arg("source") = "<string>",
      "Parses a robot description from TOML text (keys left out take the paper's values).");
  m.def(
      "paper_robot",
      [] {
        return std::make_shared<Robot>(Robot{paper_robot(), ""});
      },
      "The paper's robot with every default (no file).");
  m.def("_set_default_robot", &set_default_robot, py::arg("robot"));

  m.def("fk", &fk, py::arg("joints"), py::arg("robot") = py::none(),
        "Forward kinematics: joints (d1_m, q2_rad, q3_rad, q4_rad), shape (4,) or (N, 4) -> "
        "tool poses (x_m, y_m, z_m, yaw_rad) of the same shape. No limit check (see "
        "outside_limits).");
  m.def("ik", &ik, py::arg("poses"), py::arg("seed") = py::none(), py::arg("robot") = py::none(),
        "Inverse kinematics: poses (x_m, y_m, z_m, yaw_rad), shape (4,) or (N, 4) -> (joints, "
        "status). The solution inside the limits nearest to seed (default: home; (4,) or one "
        "row per pose). status 0 where solved, else the IkError code, with NaN joints. A (4,) "
        "pose gives a (4,) row and an int status.");
  m.def("ik_all", &ik_all, py::arg("pose"), py::arg("seed") = py::none(),
        py::arg("robot") = py::none(),
        "Every elbow solution of one pose inside the limits, nearest to seed first: shape (k, 4), "
        "k = 1 or 2. Raises UnreachableError with the reason (as `scaratwin ik` prints it).");
  m.def("jacobian", &jacobian, py::arg("joints"), py::arg("robot") = py::none(),
        "Analytic Jacobian d(x, y, z, yaw)/d(d1, q2, q3, q4): (4, 4) for one row, (N, 4, 4).");
  m.def("outside_limits", &outside_limits, py::arg("joints"), py::arg("robot") = py::none(),
        "Index (0..3) of the first joint outside its limits, -1 when inside; per row.");
  m.def("joints_to_motors", &joints_to_motors_py, py::arg("joints"), py::arg("robot") = py::none(),
        "Motor position of joints: (steps, wrist_deg), steps (N, 3) of Z, J2, J3 from the joint "
        "zero (not rounded; J3 includes the belt coupling), wrist servo angle in degrees.");
  m.def("joints_to_steps", &joints_to_steps_py, py::arg("joints"), py::arg("robot") = py::none(),
        "Nearest whole step counts of Z, J2, J3 (int32, shape (3,) or (N, 3)).");
  m.def(
      "firmware_to_joints",
      [](const py::object& joints, const py::object& robot) {
        return map_rows(joints, robot, "firmware_to_joints", &firmware_to_joints);
      },
      py::arg("joints"), py::arg("robot") = py::none(),
      "The calibration's joint map: the robot's true joints from the firmware's joint values "
      "(dead bands at their middle). The identity for a description not calibrated.");
  m.def(
      "joints_to_firmware",
      [](const py::object& joints, const py::object& robot) {
        return map_rows(joints, robot, "joints_to_firmware", &joints_to_firmware);
      },
      py::arg("joints"), py::arg("robot") = py::none(),
      "The inverse of firmware_to_joints: the firmware's joint values of true joints.");
  m.def("motors_to_joints", &motors_to_joints_py, py::arg("steps"), py::arg("wrist_deg"),
        py::arg("robot") = py::none(),
        "Joints from motor steps (Z, J2, J3; (3,) or (N, 3)) and the wrist servo angle (deg).");
}

}  // namespace scaratwin::python
