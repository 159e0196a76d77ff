#include "scaratwin/kinematics/robot_model.hpp"

#include <charconv>
#include <cmath>
#include <cstdio>
#include <initializer_list>
#include <string>
#include <utility>

#include <fmt/format.h>

#include "scaratwin/core/units.hpp"

namespace scaratwin {

RobotModel paper_robot() {
  RobotModel m;
  m.name = "paper-scara";
  // Table 1 of the paper: J1 prismatic, J2..J4 revolute, standard DH.
  m.dh[0] = {JointType::kPrismatic, 0.0, 0.0, 0.067, 0.0};
  m.dh[1] = {JointType::kRevolute, 0.0, -0.017, 0.092, 0.0};
  m.dh[2] = {JointType::kRevolute, 0.0, -0.010, 0.095, 0.0};
  m.dh[3] = {JointType::kRevolute, 0.0, -0.040, 0.0, 0.0};
  m.limits[0] = {0.01, 0.12};
  m.limits[1] = {deg_to_rad(-105.0), deg_to_rad(115.0)};
  m.limits[2] = {deg_to_rad(-75.0), deg_to_rad(205.0)};
  m.limits[3] = {deg_to_rad(0.0), deg_to_rad(180.0)};
  m.home = {0.12, 0.0, 0.0, 0.0};
  m.motors.z = {205560.0, 5000.0, 1500.0};
  m.motors.j2 = {945.0, 5000.0, 1500.0};
  m.motors.j3 = {1455.0, 5000.0, 1500.0};
  m.motors.j3_per_j2_coupling = 0.8;
  m.motors.wrist = {0.0, 180.0, 544.0, 2400.0, 300.0};
  m.motors.gripper = {0.0, 180.0, 544.0, 2400.0, 300.0};
  m.motors.gripper_open_deg = 0.0;
  m.motors.gripper_closed_deg = 75.0;
  // the switches of the authors' robot: Z at the top, J2 beyond +115 deg, J3 beyond -75 deg
  m.endstops.closes_at = {0.1225, deg_to_rad(117.0), deg_to_rad(-77.0)};
  m.endstops.homing_dir = {+1, +1, -1};
  m.endstops.pulloff_steps = 40;
  m.scene.table_z_m = -0.03;
  m.scene.cube_size_m = 0.02;
  m.scene.grasp_z_m = -0.02;
  m.scene.approach_height_m = 0.04;
  m.scene.trays[static_cast<int>(CubeColor::kRed)] = {0.130, -0.136, 0.05};
  m.scene.trays[static_cast<int>(CubeColor::kGreen)] = {0.182, -0.096, 0.05};
  m.scene.trays[static_cast<int>(CubeColor::kBlue)] = {0.212, -0.039, 0.05};
  m.scene.camera = {{0.15, 0.0, 0.45}, {0.15, 0.0, -0.03}, 45.0, 640, 480, 0.0};
  return m;
}

namespace {

Error invalid(std::string message) { return Error{ConfigError::kInvalid, std::move(message)}; }

bool finite_positive(double v) { return std::isfinite(v) && v > 0.0; }

}  // namespace

Status validate(const RobotModel& m) {
  static constexpr const char* kJoint[] = {"j1", "j2", "j3", "j4"};
  if (m.dh[0].type != JointType::kPrismatic) {
    return invalid("dh.j1.type: the first joint of a SCARA must be prismatic");
  }
  for (int i = 0; i < kNumJoints; ++i) {
    const DhRow& r = m.dh[i];
    if (i > 0 && r.type != JointType::kRevolute) {
      return invalid(fmt::format("dh.{}.type: must be revolute (only j1 is prismatic)", kJoint[i]));
    }
    for (double v : {r.theta_rad, r.d_m, r.a_m, r.alpha_rad}) {
      if (!std::isfinite(v)) return invalid(fmt::format("dh.{}: values must be finite", kJoint[i]));
    }
    if (r.alpha_rad != 0.0) {
      return invalid(fmt::format(
          "dh.{}.alpha_deg = {}: a SCARA has parallel joint axes, so every alpha must be 0",
          kJoint[i], rad_to_deg(r.alpha_rad)));
    }
    // the tool's offset off the wrist axis (dh.j4.a) may point either way: a robot as built
    // (or calibrated) with its jaws' centre a little behind the axis is a valid robot
    if (r.a_m < 0.0 && i != 3) {
      return invalid(fmt::format("dh.{}.a_m = {}: link lengths must be >= 0", kJoint[i], r.a_m));
    }
    // messages use the description file's keys and units (m for j1, degrees otherwise).
    static constexpr const char* kLimitKey[] = {"j1_m", "j2_deg", "j3_deg", "j4_deg"};
    const double scale = i == 0 ? 1.0 : kDegPerRad;
    const JointLimit& l = m.limits[i];
    if (!std::isfinite(l.min) || !std::isfinite(l.max) || !(l.min < l.max)) {
      return invalid(fmt::format("limits.{} = [{}, {}]: min must be finite and below max",
                                 kLimitKey[i], l.min * scale, l.max * scale));
    }
  }
  for (int i = 0; i < kNumJoints; ++i) {
    static constexpr const char* kHomeKey[] = {"d1_m", "q2_deg", "q3_deg", "q4_deg"};
    const double scale = i == 0 ? 1.0 : kDegPerRad;
    const JointLimit& l = m.limits[i];
    if (!l.contains(m.home[i])) {
      return invalid(fmt::format("home.{} = {}: outside the joint limits [{}, {}]", kHomeKey[i],
                                 m.home[i] * scale, l.min * scale, l.max * scale));
    }
  }
  if (m.dh[1].a_m <= 0.0 || m.dh[2].a_m <= 0.0) {
    return invalid("dh.j2.a_m and dh.j3.a_m must be > 0 (the two arm links)");
  }
  struct Named {
    const char* name;
    const StepperAxis* axis;
  };
  for (const Named& n : {Named{"motors.z", &m.motors.z}, Named{"motors.j2", &m.motors.j2},
                         Named{"motors.j3", &m.motors.j3}}) {
    if (!finite_positive(n.axis->steps_per_unit)) {
      return invalid(
          fmt::format("{}.steps_per_unit = {}: must be > 0", n.name, n.axis->steps_per_unit));
    }
    if (!finite_positive(n.axis->max_speed_steps_s)) {
      return invalid(
          fmt::format("{}.max_speed_steps_s = {}: must be > 0", n.name, n.axis->max_speed_steps_s));
    }
    if (!finite_positive(n.axis->max_accel_steps_s2)) {
      return invalid(fmt::format("{}.max_accel_steps_s2 = {}: must be > 0", n.name,
                                 n.axis->max_accel_steps_s2));
    }
  }
  if (!std::isfinite(m.motors.j3_per_j2_coupling)) {
    return invalid("motors.j3_per_j2_coupling must be finite");
  }
  for (const auto& [name, s] : {std::pair{"motors.wrist", &m.motors.wrist},
                                std::pair{"motors.gripper", &m.motors.gripper}}) {
    if (!(s->min_deg < s->max_deg) || !(s->pulse_min_us < s->pulse_max_us) ||
        s->pulse_min_us < 200 || s->pulse_max_us > 3000 || !finite_positive(s->max_speed_deg_s)) {
      return invalid(
          fmt::format("{}: needs min_deg < max_deg, 200 <= pulse_min_us < pulse_max_us <= 3000 and "
                      "max_speed_deg_s > 0",
                      name));
    }
  }
  const double wrist_min = deg_to_rad(m.motors.wrist.min_deg);
  const double wrist_max = deg_to_rad(m.motors.wrist.max_deg);
  if (m.limits[3].min < wrist_min - 1e-9 || m.limits[3].max > wrist_max + 1e-9) {
    return invalid(
        fmt::format("limits.j4 [{}, {}] deg must lie inside the wrist servo range "
                    "[{}, {}] deg",
                    rad_to_deg(m.limits[3].min), rad_to_deg(m.limits[3].max),
                    m.motors.wrist.min_deg, m.motors.wrist.max_deg));
  }
  for (double g : {m.motors.gripper_open_deg, m.motors.gripper_closed_deg}) {
    if (g < m.motors.gripper.min_deg || g > m.motors.gripper.max_deg) {
      return invalid(
          fmt::format("motors.gripper open/closed angle {} deg is outside the servo "
                      "range [{}, {}]",
                      g, m.motors.gripper.min_deg, m.motors.gripper.max_deg));
    }
  }
  // each switch must close beyond the joint's travel, on the side homing seeks it, so that
  // normal motion never reaches it
  for (int i = 0; i < 3; ++i) {
    static constexpr const char* kKey[] = {"z_m", "j2_deg", "j3_deg"};
    static constexpr const char* kLimitKey[] = {"j1_m", "j2_deg", "j3_deg"};
    const double scale = i == 0 ? 1.0 : kDegPerRad;
    const double at = m.endstops.closes_at[i];
    const int dir = m.endstops.homing_dir[i];
    const JointLimit& l = m.limits[i];
    if (dir != 1 && dir != -1) {
      return invalid(
          fmt::format("endstops.homing_dir[{}] = {}: must be 1 (the switch is beyond "
                      "the upper joint limit) or -1 (beyond the lower)",
                      i, dir));
    }
    if (!std::isfinite(at)) {
      return invalid(fmt::format("endstops.{}: must be a finite number", kKey[i]));
    }
    if (dir > 0 && !(at > l.max)) {
      return invalid(fmt::format(
          "endstops.{} = {}: homing seeks this switch upwards (endstops.homing_dir[{}] = 1), so "
          "it must close beyond the upper joint limit {} (limits.{})",
          kKey[i], at * scale, i, l.max * scale, kLimitKey[i]));
    }
    if (dir < 0 && !(at < l.min)) {
      return invalid(fmt::format(
          "endstops.{} = {}: homing seeks this switch downwards (endstops.homing_dir[{}] = -1), "
          "so it must close beyond the lower joint limit {} (limits.{})",
          kKey[i], at * scale, i, l.min * scale, kLimitKey[i]));
    }
  }
  if (m.endstops.pulloff_steps < 1 || m.endstops.pulloff_steps > 1000) {
    return invalid(fmt::format("endstops.pulloff_steps = {}: must be between 1 and 1000",
                               m.endstops.pulloff_steps));
  }
  const SceneModel& s = m.scene;
  if (!finite_positive(s.cube_size_m) || s.cube_size_m > 0.1) {
    return invalid(fmt::format("scene.cube_size_m = {}: must be in (0, 0.1]", s.cube_size_m));
  }
  if (!finite_positive(s.approach_height_m)) {
    return invalid("scene.approach_height_m must be > 0");
  }
  const CameraModel& c = s.camera;
  if (c.width_px < 16 || c.width_px > 4096 || c.height_px < 16 || c.height_px > 4096) {
    return invalid(fmt::format("scene.camera size {}x{}: width and height must be 16..4096",
                               c.width_px, c.height_px));
  }
  if (!(c.fovy_deg > 1.0 && c.fovy_deg < 170.0)) {
    return invalid(fmt::format("scene.camera.fovy_deg = {}: must be in (1, 170)", c.fovy_deg));
  }
  const PatternModel& pt = s.pattern;
  if (!std::isfinite(pt.x_m) || !std::isfinite(pt.y_m) || !(std::abs(pt.yaw_rad) <= 2 * kPi)) {
    return invalid("scene.pattern: x_m and y_m must be finite, yaw_deg in [-360, 360]");
  }
  if (!(pt.tag_size_m >= 0.005 && pt.tag_size_m <= 0.5)) {
    return invalid(
        fmt::format("scene.pattern.tag_size_m = {}: must be in [0.005, 0.5]", pt.tag_size_m));
  }
  if (!(pt.spacing_m >= pt.tag_size_m / 4 && pt.spacing_m <= 0.5)) {
    return invalid(fmt::format(
        "scene.pattern.spacing_m = {}: must be at least a quarter of tag_size_m ({}) so that "
        "each tag keeps its white border, and at most 0.5",
        pt.spacing_m, pt.tag_size_m / 4));
  }
  if (pt.columns < 1 || pt.rows < 1 || pt.columns * pt.rows > 587 || pt.columns > 64 ||
      pt.rows > 64) {
    return invalid(fmt::format(
        "scene.pattern {} x {} tags: columns and rows must be 1..64 and their product at most "
        "587 (the tag36h11 family's size)",
        pt.columns, pt.rows));
  }
  if (!(pt.thickness_m >= 0.0 && pt.thickness_m <= 0.005)) {
    return invalid(
        fmt::format("scene.pattern.thickness_m = {}: must be in [0, 0.005]", pt.thickness_m));
  }
  if (!(std::abs(c.roll_rad) <= kPi)) {
    return invalid(
        fmt::format("scene.camera.roll_deg = {}: must be in [-180, 180]", rad_to_deg(c.roll_rad)));
  }
  return Ok{};
}

Result<CubeColor> parse_color(std::string_view name) {
  if (name == "red") return CubeColor::kRed;
  if (name == "green") return CubeColor::kGreen;
  if (name == "blue") return CubeColor::kBlue;
  return Error{ConfigError::kUnknownColour,
               fmt::format("unknown colour '{}': expected red, green or blue", name)};
}

namespace {

// %.9g, whatever the locale; -0 as 0.
void put_number(std::string& out, double v) {
  if (v == 0.0) v = 0.0;
  char buf[32];
  const auto r = std::to_chars(buf, buf + sizeof buf, v, std::chars_format::general, 9);
  out.append(buf, r.ptr);
}

// key=v1,v2,...\n; `type` (a DH row's p or r), when given, is the first field.
void put_line(std::string& out, const std::string& key, std::initializer_list<double> values,
              char type = '\0') {
  out += key;
  out += '=';
  bool first = true;
  if (type != '\0') {
    out += type;
    first = false;
  }
  for (double v : values) {
    if (!first) out += ',';
    first = false;
    put_number(out, v);
  }
  out += '\n';
}

}  // namespace

std::string description_identity(const RobotModel& m) {
  std::string out;
  for (int i = 0; i < kNumJoints; ++i) {
    const DhRow& r = m.dh[i];
    const double nominal_a_m = r.a_m - m.calibration.a_delta_m[i];
    put_line(out, fmt::format("dh{}", i + 1), {r.theta_rad, r.d_m, nominal_a_m, r.alpha_rad},
             r.type == JointType::kPrismatic ? 'p' : 'r');
  }
  for (int i = 0; i < kNumJoints; ++i) {
    put_line(out, fmt::format("limit{}", i + 1), {m.limits[i].min, m.limits[i].max});
  }
  put_line(out, "home", {m.home[0], m.home[1], m.home[2], m.home[3]});
  const MotorModel& mo = m.motors;
  put_line(out, "steps_per_unit",
           {mo.z.steps_per_unit, mo.j2.steps_per_unit, mo.j3.steps_per_unit});
  put_line(out, "coupling", {mo.j3_per_j2_coupling});
  for (const auto& [key, s] :
       {std::pair{"servo_wrist", &mo.wrist}, std::pair{"servo_gripper", &mo.gripper}}) {
    put_line(out, key, {s->min_deg, s->max_deg, s->pulse_min_us, s->pulse_max_us});
  }
  const EndstopModel& e = m.endstops;
  put_line(out, "endstop_closes_at", {e.closes_at[0], e.closes_at[1], e.closes_at[2]});
  put_line(out, "endstop_homing_dir",
           {static_cast<double>(e.homing_dir[0]), static_cast<double>(e.homing_dir[1]),
            static_cast<double>(e.homing_dir[2])});
  return out;
}

std::uint32_t fnv1a32(std::string_view bytes) {
  std::uint32_t h = 2166136261u;
  for (char c : bytes) {
    h ^= static_cast<std::uint8_t>(c);
    h *= 16777619u;
  }
  return h;
}

std::string description_hash(const RobotModel& model) {
  char buf[9];
  std::snprintf(buf, sizeof buf, "%08x", fnv1a32(description_identity(model)));
  return buf;
}

}  // namespace scaratwin
