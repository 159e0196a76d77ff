#include "scaratwin/hub/tasks.hpp"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <numbers>
#include <random>
#include <thread>

#include <fmt/format.h>

#include "scaratwin/core/units.hpp"

namespace scaratwin {
namespace {

constexpr int kTaskError = error_code(HubError::kTask);

Error task_error(std::string message) { return Error{kTaskError, std::move(message)}; }

double distance(const ToolPose& a, const ToolPose& b) {
  return std::hypot(a.x_m - b.x_m, a.y_m - b.y_m, a.z_m - b.z_m);
}

// A tool heading that grasps a cube of heading `cube_yaw` (any multiple of 90 degrees from
// it: the cube is square) and that the wrist can reach at both `xy` poses.
Result<double> grasp_yaw(const RobotModel& model, const JointVector& seed, double cube_yaw,
                         const std::vector<ToolPose>& poses) {
  std::string why;
  for (int k = 0; k < 4; ++k) {
    const double yaw = wrap_angle(cube_yaw + k * kPi / 2);
    bool ok = true;
    JointVector s = seed;
    for (ToolPose p : poses) {
      p.yaw_rad = yaw;
      auto q = inverse(model, p, s);
      if (!q) {
        ok = false;
        why = q.error().message;
        break;
      }
      s = *q;
    }
    if (ok) return yaw;
  }
  return task_error(fmt::format("no gripper heading reaches the cube: {}", why));
}

}  // namespace

Result<ControlFigures> move_to(Hub& hub, const ToolPose& target, int samples) {
  const RobotModel& model = hub.model();
  auto now = hub.fresh_physical(2.0);
  if (!now) return now.error();
  // the target is judged first: one out of reach is said so whatever the robot's state
  auto goal = inverse(model, target, now->q);
  if (!goal) return task_error(fmt::format("target unreachable: {}", goal.error().message));
  now = hub.motion_start();
  if (!now) return now.error();
  auto traj = plan_quintic(model, now->q, *goal, {samples, 0.0});
  if (!traj) return traj.error();
  hub.record_event("control",
                   fmt::format("move to ({:.4f}, {:.4f}, {:.4f}) m, {} samples, "
                               "{:.2f} s",
                               target.x_m, target.y_m, target.z_m, samples, traj->duration_s()));
  auto points = hub.run_trajectory(*traj);
  if (!points) return points.error();
  // let the last reports through the mirror.
  auto phys = hub.fresh_physical(2.0);
  if (!phys) return phys.error();
  std::this_thread::sleep_for(std::chrono::milliseconds(100));
  auto sim = hub.sim_state();
  if (!sim) return sim.error();
  ControlFigures f;
  f.target = target;
  f.physical = forward(model, phys->q);
  f.virtual_ = forward(model, sim->q);
  f.target_physical_m = distance(target, f.physical);
  f.target_virtual_m = distance(target, f.virtual_);
  f.virtual_physical_m = distance(f.virtual_, f.physical);
  f.points = *points;
  return f;
}

Result<ControlFigures> move_to_position(Hub& hub, double x, double y, double z, double yaw) {
  auto now = hub.fresh_physical(2.0);
  if (!now) return now.error();
  std::string why;
  for (int k = 0; k < 24; ++k) {
    const double cand = wrap_angle(yaw + (k % 2 ? -1 : 1) * ((k + 1) / 2) * deg_to_rad(15));
    auto q = inverse(hub.model(), {x, y, z, cand}, now->q);
    if (q) return move_to(hub, {x, y, z, cand});
    why = q.error().message;
  }
  return task_error(
      fmt::format("target ({}, {}, {}) m unreachable with any heading: {}", x, y, z, why));
}

Result<SortPlan> plan_sorting(const RobotModel& model, const JointVector& start,
                              const std::vector<SortItem>& items, double speed_scale) {
  SortPlan plan;
  plan.items = items;
  plan.trajectory.samples.push_back(JointSample{0.0, start, {}, {}});
  JointVector q = start;
  const SceneModel& sc = model.scene;
  for (size_t i = 0; i < items.size(); ++i) {
    const SortItem& it = items[i];
    const Tray& tray = sc.trays[static_cast<int>(it.color)];
    ToolPose pick{it.x_m, it.y_m, sc.grasp_z_m, 0.0};
    // release a little above the tray floor: the cube drops a few millimetres.
    ToolPose place{tray.x_m, tray.y_m, sc.grasp_z_m + 0.004, 0.0};
    ToolPose above_pick = pick, above_place = place;
    above_pick.z_m += sc.approach_height_m;
    above_place.z_m += sc.approach_height_m;
    auto yaw = grasp_yaw(model, q, it.yaw_rad, {above_pick, pick});
    if (!yaw) {
      return task_error(fmt::format("{} cube at ({:.3f}, {:.3f}): {}", color_name(it.color), it.x_m,
                                    it.y_m, yaw.error().message));
    }
    pick.yaw_rad = *yaw;
    auto place_yaw = grasp_yaw(model, q, *yaw, {above_place, place});
    if (!place_yaw) {
      return task_error(
          fmt::format("{} tray: {}", color_name(it.color), place_yaw.error().message));
    }
    place.yaw_rad = *place_yaw;
    PickPlaceRequest r;
    r.pick = pick;
    r.place = place;
    r.approach_height_m = sc.approach_height_m;
    r.speed_scale = speed_scale;
    r.accel_scale = speed_scale;
    auto seg = plan_pick_place(model, q, r);
    if (!seg) {
      return task_error(fmt::format("{} cube at ({:.3f}, {:.3f}): {}", color_name(it.color), it.x_m,
                                    it.y_m, seg.error().message));
    }
    append(plan.trajectory, *seg);
    q = plan.trajectory.samples.back().q;
  }
  if (Status s = check_limits(model, plan.trajectory); !s) return s.error();
  return plan;
}

namespace {

// Distance in the table's plane from (x, y) to the segment a-b.
double to_segment(double x, double y, const std::array<double, 2>& a,
                  const std::array<double, 2>& b) {
  const double dx = b[0] - a[0], dy = b[1] - a[1];
  const double len2 = dx * dx + dy * dy;
  double u = len2 > 0.0 ? ((x - a[0]) * dx + (y - a[1]) * dy) / len2 : 0.0;
  u = std::clamp(u, 0.0, 1.0);
  return std::hypot(x - (a[0] + u * dx), y - (a[1] + u * dy));
}

}  // namespace

Result<std::vector<SortItem>> random_layout(const RobotModel& model, std::uint64_t seed, int cubes,
                                            const JointVector& arm, double min_gap_m) {
  std::mt19937_64 rng(seed);
  const double a1 = model.dh[0].a_m;
  const double reach = model.dh[1].a_m + model.dh[2].a_m;
  const double cube = model.scene.cube_size_m;
  std::uniform_real_distribution<double> radius(0.45 * reach, 0.92 * reach);
  std::uniform_real_distribution<double> angle(-0.5 * std::numbers::pi, 0.5 * std::numbers::pi);
  const CameraModel& cam = model.scene.camera;
  // the arm seen from above: column -> shoulder axis -> elbow -> wrist
  const double a2 = model.dh[1].a_m, a3 = model.dh[2].a_m;
  const std::array<double, 2> column{0.0, 0.0}, shoulder{a1, 0.0};
  const std::array<double, 2> elbow{a1 + a2 * std::cos(arm[1]), a2 * std::sin(arm[1])};
  const std::array<double, 2> wrist{elbow[0] + a3 * std::cos(arm[1] + arm[2]),
                                    elbow[1] + a3 * std::sin(arm[1] + arm[2])};
  const auto spot_ok = [&](double x, double y) {
    if (std::hypot(x, y) < 0.06) return false;
    if (to_segment(x, y, column, shoulder) < kArmClearance_m ||
        to_segment(x, y, shoulder, elbow) < kArmClearance_m ||
        to_segment(x, y, elbow, wrist) < kArmClearance_m) {
      return false;  // under the arm: the cameras would not see it
    }
    for (const Tray& t : model.scene.trays) {
      const double margin = 0.5 * t.size_m + cube;
      if (std::abs(x - t.x_m) < margin && std::abs(y - t.y_m) < margin) return false;
    }
    double col = 0.0, row = 0.0;
    if (!project(cam, cam.width_px, cam.height_px, {x, y, model.scene.table_z_m + 0.5 * cube}, col,
                 row)) {
      return false;
    }
    const double edge = 0.05 * cam.width_px;
    if (col < edge || row < edge || col > cam.width_px - edge || row > cam.height_px - edge) {
      return false;
    }
    for (double yaw : {0.0, 0.5 * std::numbers::pi, std::numbers::pi, -0.5 * std::numbers::pi}) {
      ToolPose pose;
      pose.x_m = x;
      pose.y_m = y;
      pose.z_m = model.scene.grasp_z_m;
      pose.yaw_rad = yaw;
      if (inverse(model, pose, model.home)) return true;
    }
    return false;
  };
  std::vector<SortItem> out;
  for (int c = 0; c < cubes; ++c) {
    bool placed = false;
    for (int attempt = 0; attempt < 1000 && !placed; ++attempt) {
      const double r = radius(rng);
      const double a = angle(rng);
      const SortItem it{static_cast<CubeColor>(c % kNumColors), a1 + r * std::cos(a),
                        r * std::sin(a), 0.0};
      if (!spot_ok(it.x_m, it.y_m)) continue;
      bool apart = true;
      for (const SortItem& o : out)
        apart = apart && std::hypot(o.x_m - it.x_m, o.y_m - it.y_m) > min_gap_m;
      if (!apart) continue;
      out.push_back(it);
      placed = true;
    }
    if (!placed) {
      return task_error(
          fmt::format("random layout (seed {}): no free spot for cube {} of {} in "
                      "1000 draws (fewer cubes, or a smaller gap than {:.3f} m)",
                      seed, c + 1, cubes, min_gap_m));
    }
  }
  return out;
}

Result<std::vector<SortItem>> recognise_cubes(Hub& hub, const RobotModel& model) {
  auto png = hub.shoot();
  if (!png) return png.error();
  auto img = decode_png(*png);
  if (!img) return img.error();
  std::vector<SortItem> out;
  for (const CubeDetection& d : detect_cubes(*img, model)) {
    out.push_back({d.color, d.x_m, d.y_m, 0.0});
  }
  hub.record_event("vision", fmt::format("{} cubes recognised", out.size()));
  return out;
}

int cubes_in_trays(const RobotModel& model, const std::vector<protocol::ObjectPose>& objects) {
  int n = 0;
  for (const protocol::ObjectPose& o : objects) {
    const Tray& t = model.scene.trays[static_cast<int>(o.color)];
    const double half = 0.5 * t.size_m;
    if (std::abs(o.x_m - t.x_m) <= half && std::abs(o.y_m - t.y_m) <= half &&
        o.z_m < model.scene.table_z_m + 2.0 * model.scene.cube_size_m) {
      ++n;
    }
  }
  return n;
}

}  // namespace scaratwin
