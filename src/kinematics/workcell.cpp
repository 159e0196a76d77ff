// The workcell: robots with base poses around one scene (see workcell.hpp).
#include "scaratwin/kinematics/workcell.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include <fmt/format.h>

#include "scaratwin/core/units.hpp"

namespace scaratwin {
namespace {

using Vec3 = std::array<double, 3>;

Error invalid(std::string message) { return Error{ConfigError::kInvalid, std::move(message)}; }

double mm(double m) { return m_to_mm(m); }

bool good_name(const std::string& name) {
  if (name.empty() || name.size() > kMaxRobotNameLength) return false;
  return std::all_of(name.begin(), name.end(), [](char c) {
    return (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '_' || c == '-';
  });
}

// Distance between the segments ab and cd of the plane.
struct P2 {
  double x, y;
};
double cross2(P2 o, P2 a, P2 b) { return (a.x - o.x) * (b.y - o.y) - (a.y - o.y) * (b.x - o.x); }
double point_segment(P2 p, P2 a, P2 b) {
  const double dx = b.x - a.x, dy = b.y - a.y, l2 = dx * dx + dy * dy;
  double t = l2 > 0.0 ? ((p.x - a.x) * dx + (p.y - a.y) * dy) / l2 : 0.0;
  t = std::clamp(t, 0.0, 1.0);
  return std::hypot(p.x - (a.x + t * dx), p.y - (a.y + t * dy));
}
double segment_segment(P2 a, P2 b, P2 c, P2 d) {
  const double d1 = cross2(c, d, a), d2 = cross2(c, d, b);
  const double d3 = cross2(a, b, c), d4 = cross2(a, b, d);
  if (((d1 > 0 && d2 < 0) || (d1 < 0 && d2 > 0)) && ((d3 > 0 && d4 < 0) || (d3 < 0 && d4 > 0))) {
    return 0.0;  // proper crossing
  }
  return std::min({point_segment(a, c, d), point_segment(b, c, d), point_segment(c, a, b),
                   point_segment(d, a, b)});
}

}  // namespace

Workcell single_robot_workcell(const RobotModel& model) {
  Workcell w;
  w.scene = model.scene;
  w.robots.push_back(RobotInstance{"robot", BasePose{}, model, {}});
  return w;
}

double distance_to_segment_xy(const Vec3& p, const Vec3& a, const Vec3& b) {
  return point_segment({p[0], p[1]}, {a[0], a[1]}, {b[0], b[1]});
}

Vec3 base_to_world(const BasePose& b, const Vec3& p) {
  const double c = std::cos(b.yaw_rad), s = std::sin(b.yaw_rad);
  return {b.x_m + c * p[0] - s * p[1], b.y_m + s * p[0] + c * p[1], b.z_m + p[2]};
}

Vec3 world_to_base(const BasePose& b, const Vec3& p) {
  const double c = std::cos(b.yaw_rad), s = std::sin(b.yaw_rad);
  const double dx = p[0] - b.x_m, dy = p[1] - b.y_m;
  return {c * dx + s * dy, -s * dx + c * dy, p[2] - b.z_m};
}

std::array<Vec3, 5> home_arm_points(const Workcell& w, int robot) {
  SCARATWIN_CHECK(robot >= 0 && robot < static_cast<int>(w.robots.size()), "robot index");
  return arm_points(w, robot, w.robots[robot].model.home);
}

double arm_distance(const Workcell& w, int a, const JointVector& q_a, int b,
                    const JointVector& q_b) {
  const auto pa = arm_points(w, a, q_a);
  const auto pb = arm_points(w, b, q_b);
  double closest = INFINITY;
  for (std::size_t s = 0; s + 1 < pa.size(); ++s) {
    for (std::size_t t = 0; t + 1 < pb.size(); ++t) {
      closest =
          std::min(closest, segment_segment({pa[s][0], pa[s][1]}, {pa[s + 1][0], pa[s + 1][1]},
                                            {pb[t][0], pb[t][1]}, {pb[t + 1][0], pb[t + 1][1]}));
    }
  }
  return closest;
}

std::array<Vec3, 5> arm_points(const Workcell& w, int robot, const JointVector& q) {
  SCARATWIN_CHECK(robot >= 0 && robot < static_cast<int>(w.robots.size()), "robot index");
  const RobotInstance& r = w.robots[robot];
  const auto& dh = r.model.dh;
  // the planar DH chain (a SCARA has alpha = 0): heading and position of each joint axis
  std::array<Vec3, 5> p{};
  double heading = dh[0].theta_rad;
  double x = 0.0, y = 0.0, z = q[0] + dh[0].d_m;
  for (int i = 0; i < kNumJoints; ++i) {
    if (i > 0) {
      heading += dh[i].theta_rad + q[i];
      z += dh[i].d_m;
    }
    x += dh[i].a_m * std::cos(heading);
    y += dh[i].a_m * std::sin(heading);
    p[i + 1] = {x, y, z};
  }
  p[0] = {0.0, 0.0, 0.0};
  for (Vec3& v : p) v = base_to_world(r.base, v);
  return p;
}

Status validate(const Workcell& w) {
  if (w.robots.empty()) return invalid("workcell: no robot (give at least one [[robot]])");
  const std::size_t n = w.robots.size();
  for (std::size_t i = 0; i < n; ++i) {
    const RobotInstance& r = w.robots[i];
    if (n > 1 && !good_name(r.name)) {
      return invalid(fmt::format(
          "robot {} name '{}': must be 1..{} characters of a-z, 0-9, '_' and '-' (it prefixes "
          "the robot's names in the model)",
          i, r.name, kMaxRobotNameLength));
    }
    for (std::size_t j = 0; j < i; ++j) {
      if (w.robots[j].name == r.name) {
        return invalid(
            fmt::format("robot name '{}' is used twice (robots {} and {})", r.name, j, i));
      }
    }
    if (Status s = validate(r.model); !s) {
      return invalid(fmt::format(
          "robot '{}' ({}): {}", r.name,
          r.description_file.empty() ? "its description" : r.description_file, s.error().message));
    }
    const BasePose& b = r.base;
    if (!std::isfinite(b.x_m) || !std::isfinite(b.y_m) || !std::isfinite(b.z_m) ||
        !std::isfinite(b.yaw_rad)) {
      return invalid(fmt::format("robot '{}': base pose ({}, {}, {}) mm, yaw {} deg: not finite",
                                 r.name, mm(b.x_m), mm(b.y_m), mm(b.z_m), rad_to_deg(b.yaw_rad)));
    }
  }
  const BasePose& b0 = w.robots[0].base;
  if (b0.x_m != 0.0 || b0.y_m != 0.0 || b0.z_m != 0.0 || b0.yaw_rad != 0.0) {
    return invalid(fmt::format(
        "robot '{}' (the first) is at ({:.1f}, {:.1f}, {:.1f}) mm, yaw {:.1f} deg: the first robot "
        "must stand at "
        "the origin with yaw 0 (its base frame is the world frame; move the others instead)",
        w.robots[0].name, mm(b0.x_m), mm(b0.y_m), mm(b0.z_m), rad_to_deg(b0.yaw_rad)));
  }
  // bases and arms apart, seen from above
  for (std::size_t i = 0; i < n; ++i) {
    for (std::size_t j = i + 1; j < n; ++j) {
      const RobotInstance& a = w.robots[i];
      const RobotInstance& b = w.robots[j];
      const double d = std::hypot(a.base.x_m - b.base.x_m, a.base.y_m - b.base.y_m);
      if (d < kMinBaseDistanceM) {
        return invalid(fmt::format(
            "robots '{}' and '{}': bases at ({:.1f}, {:.1f}) mm and ({:.1f}, {:.1f}) mm are "
            "{:.1f} mm apart: they must be at least {:.0f} mm apart",
            a.name, b.name, mm(a.base.x_m), mm(a.base.y_m), mm(b.base.x_m), mm(b.base.y_m), mm(d),
            mm(kMinBaseDistanceM)));
      }
      const auto pa = home_arm_points(w, static_cast<int>(i));
      const auto pb = home_arm_points(w, static_cast<int>(j));
      const double closest =
          arm_distance(w, static_cast<int>(i), a.model.home, static_cast<int>(j), b.model.home);
      if (closest < kMinArmDistanceM) {
        return invalid(fmt::format(
            "robots '{}' and '{}': their arms at home come {:.1f} mm close seen from above "
            "(wrists at ({:.1f}, {:.1f}) mm and ({:.1f}, {:.1f}) mm): they must stay at least "
            "{:.0f} mm apart; move or turn a base",
            a.name, b.name, mm(closest), mm(pa[3][0]), mm(pa[3][1]), mm(pb[3][0]), mm(pb[3][1]),
            mm(kMinArmDistanceM)));
      }
    }
  }
  // no base in a tray (the footprint: the inner square and its 3 mm walls)
  for (const RobotInstance& r : w.robots) {
    for (int c = 0; c < kNumColors; ++c) {
      const Tray& t = w.scene.trays[c];
      const double half = 0.5 * t.size_m + 0.003;
      if (std::abs(r.base.x_m - t.x_m) <= half && std::abs(r.base.y_m - t.y_m) <= half) {
        return invalid(fmt::format(
            "robot '{}': its base at ({:.1f}, {:.1f}) mm is inside the {} tray (centre ({:.1f}, "
            "{:.1f}) mm, {:.1f} mm across)",
            r.name, mm(r.base.x_m), mm(r.base.y_m), color_name(CubeColor(c)), mm(t.x_m), mm(t.y_m),
            mm(2 * half)));
      }
    }
  }
  return Ok{};
}

std::string robot_names(const Workcell& w) {
  std::string s;
  for (const RobotInstance& r : w.robots) s += (s.empty() ? "'" : ", '") + r.name + "'";
  return s;
}

Result<int> robot_index(const Workcell& w, std::string_view name) {
  for (std::size_t i = 0; i < w.robots.size(); ++i) {
    if (w.robots[i].name == name) return static_cast<int>(i);
  }
  return Error{ConfigError::kUnknownRobot,
               fmt::format("no robot named '{}' in the workcell (robots: {})", name,
                           w.robots.empty() ? std::string("none") : robot_names(w))};
}

RobotModel scene_in_base(const Workcell& w, int robot) {
  SCARATWIN_CHECK(robot >= 0 && robot < static_cast<int>(w.robots.size()), "robot index");
  const BasePose& b = w.robots[robot].base;
  RobotModel m = w.robots[robot].model;
  SceneModel s = w.scene;
  s.table_z_m -= b.z_m;
  s.grasp_z_m -= b.z_m;
  for (Tray& t : s.trays) {
    const Vec3 p = world_to_base(b, {t.x_m, t.y_m, 0.0});
    t.x_m = p[0];
    t.y_m = p[1];
  }
  CameraModel& cam = s.camera;
  cam.pos_m = world_to_base(b, cam.pos_m);
  cam.look_at_m = world_to_base(b, cam.look_at_m);
  // vision's camera_axes() takes the image's "up" from W's x axis when the camera looks
  // (nearly) straight down, and from z otherwise: only the first turns with the base
  const double fx = cam.look_at_m[0] - cam.pos_m[0], fy = cam.look_at_m[1] - cam.pos_m[1],
               fz = cam.look_at_m[2] - cam.pos_m[2];
  const double fn = std::sqrt(fx * fx + fy * fy + fz * fz);
  // (the camera's z axis is -f: W's z looking down, -z looking up)
  if (b.yaw_rad != 0.0 && fn > 0.0 && std::abs(fz / fn) > 0.999) {
    const double turn = fz < 0.0 ? -b.yaw_rad : b.yaw_rad;
    cam.roll_rad = std::remainder(cam.roll_rad + turn, 2.0 * kPi);
  }
  const Vec3 pat = world_to_base(b, {s.pattern.x_m, s.pattern.y_m, 0.0});
  s.pattern.x_m = pat[0];
  s.pattern.y_m = pat[1];
  if (b.yaw_rad != 0.0) {
    s.pattern.yaw_rad = std::remainder(s.pattern.yaw_rad - b.yaw_rad, 2.0 * kPi);
  }
  m.scene = s;
  return m;
}

}  // namespace scaratwin
