#include "scaratwin/hub/calibrate.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <map>
#include <numbers>
#include <utility>

#include <fmt/format.h>

#include "scaratwin/core/units.hpp"
#include "scaratwin/kinematics/kinematics.hpp"
#include "scaratwin/sim/mjcf.hpp"
#include "scaratwin/trajectory/trajectory.hpp"
#include "scaratwin/vision/webcam.hpp"

namespace scaratwin {
namespace {

constexpr double kDeg = std::numbers::pi / 180.0;

void say(const CalibrationOptions& o, const std::string& line) {
  if (o.progress) o.progress(line);
}

// The robot's firmware joints now (its counts through the base description) and the side of
// the dead band each joint rests on.
struct Reading {
  JointVector q_fw{};
  calib::Directions dir{};
  std::uint32_t device_us = 0;
};

Result<Reading> read_robot(Hub& hub) {
  auto ps = hub.fresh_physical(2.0);
  if (!ps) return ps.error();
  Reading r;
  r.q_fw = ps->q;  // the base description: its joints are the firmware's
  const MotionDirections d = hub.directions();
  r.dir = {d[0], d[1], d[2], 0};
  r.device_us = ps->raw.t_us;
  return r;
}

Status move_to(Hub& hub, const JointVector& target) {
  auto now = hub.fresh_physical(2.0);
  if (!now) return now.error();
  auto traj = plan_quintic(hub.model(), now->q, target);
  if (!traj) return traj.error();
  auto run = hub.run_trajectory(*traj);
  if (!run) return run.error();
  return hub.wait_idle(30.0);
}

// each joint's side for pose i (seeded, so every joint reaches poses from both sides)
MotionDirections sides(std::uint64_t seed, std::size_t i) {
  std::uint64_t s = seed * 0x9E3779B97F4A7C15ULL + 77 * i + 1;
  MotionDirections d{};
  d[0] = seeded_uniform(s, 0.0, 1.0) < 0.5 ? -1 : 1;
  // J2 and J3 from the same side: J3's last motion moves the upper arm across its own dead
  // band (seen in the truth: J2 rested on the flank J3's direction chose), so only the same
  // side for both leaves each joint where its own direction says
  d[1] = d[2] = seeded_uniform(s, 0.0, 1.0) < 0.5 ? -1 : 1;
  return d;
}

Result<RgbImage> picture(NetCamera& camera, const CalibrationOptions& o, int& count) {
  auto frame = camera.grab(o.width_px, o.height_px);
  if (!frame) return Error{frame.error().code, "calibration: the webcam: " + frame.error().message};
  ++count;
  return std::move(frame->image);
}

}  // namespace

Status approach(Hub& hub, const JointVector& target, const MotionDirections& dir) {
  auto now = hub.fresh_physical(2.0);
  if (!now) return now.error();
  JointVector before = target;
  before[0] -= dir[0] * 0.00025;  // 10 times the lead screw's play
  before[1] -= dir[1] * 1.5 * kDeg;
  before[2] -= dir[2] * 1.5 * kDeg;
  // near a limit the run-up is shorter (its last part is still towards `dir`)
  for (int j = 0; j < 3; ++j) {
    const JointLimit& lim = hub.model().limits[j];
    before[j] = std::clamp(before[j], lim.min, lim.max);
  }
  // one trajectory (no stop to wait for between its parts): quick to `before`, then slow, Z
  // and J2 first, then J3 alone: the elbow link moving with the upper arm comes to rest on
  // whichever flank the upper arm's motion leaves it (seen in the truth: J3's side followed
  // J2's direction when both moved together)
  auto motion = plan_quintic(hub.model(), now->q, before);
  if (!motion) return motion.error();
  JointVector mid = target;
  mid[2] = before[2];
  for (const auto& [from, to] : {std::pair{before, mid}, std::pair{mid, target}}) {
    // slow for the belts (2.5 times their shortest time); the lead screw holds where it stops
    JointVector belts_only = from;
    belts_only[0] = to[0];
    const double t = std::max({0.5, quintic_min_duration(hub.model(), from, to),
                               2.5 * quintic_min_duration(hub.model(), belts_only, to)});
    auto slow = plan_quintic(hub.model(), from, to, {20, t});
    if (!slow) return slow.error();
    append(*motion, *slow);
  }
  auto run = hub.run_trajectory(*motion);
  if (!run) return run.error();
  return hub.wait_idle(30.0);
}

double seeded_uniform(std::uint64_t& s, double lo, double hi) {
  std::uint64_t z = (s += 0x9E3779B97F4A7C15ULL);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
  z ^= z >> 31;
  return lo + (hi - lo) * static_cast<double>(z >> 11) * 0x1.0p-53;
}

bool is_calibrated(const RobotModel& m) {
  const JointCalibration& c = m.calibration;
  return m.webcam.valid || c.z_offset_m != 0.0 || c.z_scale != 0.0 || c.j2_zero_rad != 0.0 ||
         c.j3_zero_rad != 0.0 || c.wrist_offset_rad != 0.0 || c.wrist_gain != 0.0 ||
         c.backlash != std::array<double, 3>{};
}

std::vector<std::pair<std::string, std::array<double, 3>>> touch_marks(const RobotModel& model) {
  // crosses printed on the mat the robot stands on (registered to its base), clear of the
  // trays; the tool point 15 mm above the table (a gauge block under the jaws)
  const double z = model.scene.table_z_m + 0.015;
  return {{"mark A", {0.10, 0.15, z}}, {"mark D", {0.23, 0.02, z}}, {"mark E", {0.14, 0.06, z}},
          {"mark B", {0.18, 0.11, z}}, {"mark C", {0.22, 0.06, z}}, {"mark F", {0.17, 0.03, z}}};
}

std::vector<JointVector> visiting_order(const RobotModel& model, std::vector<JointVector> poses) {
  // a move's duration grows with the square root of its distance over the acceleration
  // (a quintic: peak acceleration 5.77 d / T^2); the slowest joint sets it
  const MotorModel& m = model.motors;
  const std::array<double, 3> accel{m.z.max_accel_steps_s2 / m.z.steps_per_unit,
                                    m.j2.max_accel_steps_s2 / m.j2.steps_per_unit,
                                    m.j3.max_accel_steps_s2 / m.j3.steps_per_unit};
  const auto cost = [&accel](const JointVector& a, const JointVector& b) {
    double t = 0.0;
    for (int j = 0; j < 3; ++j) t = std::max(t, std::sqrt(5.77 * std::abs(a[j] - b[j]) / accel[j]));
    return t;
  };
  std::vector<JointVector> out;
  // one elbow configuration, then the other (switching costs the longest J3 move)
  for (const bool up : {true, false}) {
    std::vector<JointVector> group;
    for (const JointVector& q : poses) {
      if ((q[2] >= 0.0) == up) group.push_back(q);
    }
    if (group.empty()) continue;
    JointVector at = out.empty() ? model.home : out.back();
    while (!group.empty()) {
      auto next = std::min_element(group.begin(), group.end(), [&](const auto& a, const auto& b) {
        return cost(at, a) < cost(at, b);
      });
      at = *next;
      out.push_back(at);
      group.erase(next);
    }
  }
  return out;
}

std::vector<JointVector> marker_poses(const RobotModel& model, const WebcamModel& cam, int count,
                                      std::uint64_t seed) {
  std::vector<JointVector> out;
  const auto& lim = model.limits;
  std::uint64_t s = seed * 0x2545F4914F6CDD1DULL + 1;
  int tries = 0;
  while (static_cast<int>(out.size()) < count && tries++ < 100000) {
    const bool elbow_up = out.size() % 2 == 0;
    JointVector q;
    // high enough that the jaws clear the trays; the joints a margin inside their limits
    // Z stratified: pose k in the k-th of `count` slices of the travel, so the heights span it
    const double z_lo = std::max(lim[0].min, 0.075), z_hi = lim[0].max - 0.002;
    const double slice = (z_hi - z_lo) / count;
    q[0] = z_lo + slice * (static_cast<double>(out.size()) + seeded_uniform(s, 0.0, 1.0));
    q[1] = seeded_uniform(s, std::max(lim[1].min + 15 * kDeg, -95 * kDeg),
                          std::min(lim[1].max - 15 * kDeg, 95 * kDeg));
    q[2] = elbow_up ? seeded_uniform(s, 30 * kDeg, std::min(lim[2].max - 15 * kDeg, 140 * kDeg))
                    : seeded_uniform(s, std::max(lim[2].min + 8 * kDeg, -140 * kDeg), -25 * kDeg);
    q[3] = seeded_uniform(s, std::max(lim[3].min, 10 * kDeg), std::min(lim[3].max, 170 * kDeg));
    // both markers well inside the picture, as the pattern's camera sees it (its lens
    // moves the picture's edges by tens of pixels): a disc cut by the edge is not seen whole
    const auto a = calib::axis_marker_B(model, q);
    const auto inside = [&cam](const std::array<double, 3>& p, double radius) {
      double col = 0.0, row = 0.0;
      constexpr double kMargin = 48.0, kW = 1280.0, kH = 960.0;
      return project_disc(cam, p, radius, static_cast<int>(kW), static_cast<int>(kH), col, row) &&
             col > kMargin && col < kW - kMargin && row > kMargin && row < kH - kMargin;
    };
    if (!inside(a, sim::kMarkerRadiusM) ||
        !inside(calib::flag_marker_B(model, q), sim::kFlagMarkerRadiusM)) {
      continue;
    }
    // not over the robot's own base column
    if (std::hypot(a[0], a[1]) < 0.09) continue;
    out.push_back(q);
  }
  return visiting_order(model, std::move(out));
}

Result<CalibrationRun> calibrate(Hub& hub, NetCamera& camera, CalibrationOperator& op,
                                 const CalibrationOptions& o) {
  const RobotModel& base = hub.model();
  if (is_calibrated(base)) {
    return Error{CalibrationError::kCalibratedBase,
                 "calibrate: the hub runs a calibrated description; calibrate with its base "
                 "description (the overlay's `base`)"};
  }
  CalibrationRun run;
  calib::Measurements& m = run.measurements;
  const auto t0 = std::chrono::steady_clock::now();

  say(o, "home against the endstops (the joint zeros are measured from the switches)");
  if (Status s = hub.home(); !s) return s.error();
  auto first = read_robot(hub);
  if (!first) return first.error();
  std::uint64_t device_us = 0;  // the robot's clock since homing, unwrapped
  std::uint32_t last_us = first->device_us;
  auto tick = [&](std::uint32_t us) {
    device_us += static_cast<std::uint32_t>(us - last_us);
    last_us = us;
  };
  const auto robot_s = [&device_us] { return static_cast<double>(device_us) / 1e6; };

  // 1. the printed pattern, seen with the arm to one side and then the other (each tag from
  // the picture where the arm does not hide it)
  say(o, "lay the printed pattern on the table; the webcam measures itself against it");
  if (Status s = op.pattern(true); !s) return s.error();
  std::map<int, TagCorners> tags;
  for (double side : {1.0, -1.0}) {
    const JointVector aside{base.limits[0].max - 0.002, side * 100.0 * kDeg, side * 40.0 * kDeg,
                            90.0 * kDeg};
    if (Status s = move_to(hub, aside); !s) return s.error();
    if (Status s = hub.sleep(o.settle_s); !s) return s.error();
    auto img = picture(camera, o, run.pictures);
    if (!img) return img.error();
    const std::vector<TagCorners> seen = detect_tags(*img);
    for (const TagCorners& t : seen) tags.emplace(t.id, t);
    say(o, fmt::format("  {} tags seen", seen.size()));
  }
  if (Status s = op.pattern(false); !s) return s.error();
  std::vector<TagCorners> all;
  for (const auto& [id, t] : tags) all.push_back(t);
  auto cam =
      calibrate_webcam(nominal_webcam(base.scene.camera), all, o.width_px, o.height_px, base);
  if (!cam) {
    return Error{cam.error().code,
                 "calibration: the webcam on the pattern: " + cam.error().message};
  }
  say(o, fmt::format("  the webcam: {} tags, {} corners, residual {:.2f} px{}", cam->tags,
                     cam->corners, cam->rms_px, cam->note.empty() ? "" : "; " + cam->note));
  run.camera = *cam;
  calib::CameraPrior prior{cam->camera, cam->std_error, cam->corners};

  // 2. the markers at poses over the workspace
  const std::vector<JointVector> poses = marker_poses(base, cam->camera, o.marker_poses, o.seed);
  say(o, fmt::format("the tool's markers at {} poses", poses.size()));
  int unseen = 0;
  for (std::size_t i = 0; i < poses.size(); ++i) {
    const MotionDirections side = sides(o.seed, i);
    if (Status s = approach(hub, poses[i], side); !s) return s.error();
    if (Status s = hub.sleep(o.settle_s); !s) return s.error();
    auto r = read_robot(hub);
    if (!r) return r.error();
    tick(r->device_us);
    auto img = picture(camera, o, run.pictures);
    if (!img) return img.error();
    calib::MarkerView v;
    v.q_fw = r->q_fw;
    v.dir = {side[0], side[1], side[2], 0};
    v.width_px = img->width;
    v.height_px = img->height;
    double col = 0.0, row = 0.0;
    if (detect_marker(*img, col, row)) v.axis_px = std::array<double, 2>{col, row};
    if (detect_flag_marker(*img, col, row)) v.flag_px = std::array<double, 2>{col, row};
    if (!v.axis_px) ++unseen;
    m.markers.push_back(v);
    if (o.on_measurement) o.on_measurement(&m.markers.back(), nullptr);
    if ((i + 1) % 6 == 0) {
      say(o,
          fmt::format("  {} of {} poses ({:.0f} s of robot time)", i + 1, poses.size(), robot_s()));
    }
  }
  if (unseen > static_cast<int>(poses.size()) / 4) {
    return Error{CalibrationError::kMarkerNotFound,
                 fmt::format("calibration: the tool marker was not found in {} of {} pictures "
                             "(is the marker on the tool, and the webcam's view clear?)",
                             unseen, poses.size())};
  }

  // 3. touch-offs, at three wrist angles
  auto marks = touch_marks(base);
  marks.resize(std::min(marks.size(), static_cast<std::size_t>(std::max(o.touch_offs, 0))));
  say(o, fmt::format("touch-offs: the tool onto {} marks", marks.size()));
  static constexpr double kWrist[] = {20.0, 90.0, 160.0};
  for (std::size_t i = 0; i < marks.size(); ++i) {
    const auto& [name, p] = marks[i];
    auto now = hub.fresh_physical(2.0);
    if (!now) return now.error();
    // the description's IK near the current joints for the position; then the wrist joint
    // at this mark's angle (it hardly moves the tool point: the operator makes up for it)
    auto q_above = Result<JointVector>(Error{CalibrationError::kUnreachable, "no wrist angle"});
    for (double yaw = -180.0; yaw < 180.0 && !q_above; yaw += 30.0) {
      q_above = inverse(base, ToolPose{p[0], p[1], p[2] + 0.008, yaw * kDeg}, now->q);
    }
    if (!q_above) {
      return Error{CalibrationError::kUnreachable,
                   fmt::format("calibration: {} at ({:.0f}, {:.0f}) mm is out of reach: {}", name,
                               p[0] * 1e3, p[1] * 1e3, q_above.error().message)};
    }
    (*q_above)[3] = kWrist[i % 3] * kDeg;
    if (Status s = move_to(hub, *q_above); !s) return s.error();
    JointVector q_on = *q_above;
    q_on[0] -= 0.008;
    if (Status s = move_to(hub, q_on); !s) return s.error();
    if (Status s = op.touch_off(hub, name, p); !s) return s.error();
    if (Status s = hub.sleep(o.settle_s); !s) return s.error();
    auto r = read_robot(hub);
    if (!r) return r.error();
    tick(r->device_us);
    m.touches.push_back({name, p, r->q_fw, r->dir});
    say(o, fmt::format("  {} ({:.0f} s of robot time)", name, robot_s()));
    if (o.on_measurement) o.on_measurement(nullptr, &m.touches.back());
    // lift clear before the next
    JointVector up = r->q_fw;
    up[0] = std::min(base.limits[0].max - 0.002, up[0] + 0.008);
    if (Status s = move_to(hub, up); !s) return s.error();
  }
  run.robot_s = robot_s();

  say(o, "fit");
  const auto f0 = std::chrono::steady_clock::now();
  auto fit = calib::fit(base, prior, m, o.fit);
  const double fit_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - f0).count();
  if (!fit) return fit.error();
  run.fit = std::move(*fit);
  run.fit.fit_seconds = fit_s;
  run.calibrated = calib::apply(base, run.fit);
  (void)t0;
  return run;
}

}  // namespace scaratwin
