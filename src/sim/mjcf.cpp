// MJCF and URDF generation from the robot description (see mjcf.hpp).
#include "scaratwin/sim/mjcf.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <string>

#include <fmt/format.h>

#include "scaratwin/core/units.hpp"
#include "scaratwin/vision/vision.hpp"
#include "scaratwin/vision/webcam.hpp"

namespace scaratwin::sim {
namespace {

using Vec3 = std::array<double, 3>;

// Shortest round-trip representation, so that the model is exactly the description.
std::string num(double v) { return fmt::format("{:.17g}", v); }
std::string vec(double a, double b, double c) {
  return fmt::format("{} {} {}", num(a), num(b), num(c));
}

// Quaternion (w x y z) of Rx(alpha) * Rz(theta): the fixed rotation between two DH bodies.
std::string quat_xz(double alpha, double theta) {
  const double ca = std::cos(alpha / 2), sa = std::sin(alpha / 2);
  const double ct = std::cos(theta / 2), st = std::sin(theta / 2);
  return fmt::format("{} {} {} {}", num(ca * ct), num(sa * ct), num(-sa * st), num(ca * st));
}

Vec3 sub(const Vec3& a, const Vec3& b) { return {a[0] - b[0], a[1] - b[1], a[2] - b[2]}; }
double norm(const Vec3& a) { return std::sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2]); }

constexpr std::array<const char*, kNumColors> kCubeRgba = {"0.85 0.08 0.08 1", "0.08 0.65 0.12 1",
                                                           "0.08 0.2 0.9 1"};
constexpr std::array<const char*, kNumColors> kTrayRgba = {"0.75 0.55 0.55 1", "0.55 0.72 0.55 1",
                                                           "0.55 0.6 0.78 1"};

Error bad_option(std::string message) { return Error{SimError::kBadArgument, std::move(message)}; }

// Roll, pitch, yaw (URDF convention R = Rz(yaw) Ry(pitch) Rx(roll)) of Rx(alpha) Rz(theta).
Vec3 rpy_xz(double alpha, double theta) {
  // R = Rx(a) Rz(t): rows [ct, -st, 0; ca st, ca ct, -sa; sa st, sa ct, ca]
  const double ca = std::cos(alpha), sa = std::sin(alpha);
  const double ct = std::cos(theta), st = std::sin(theta);
  const double r00 = ct, r10 = ca * st, r20 = sa * st, r21 = sa * ct, r22 = ca;
  return {std::atan2(r21, r22), std::atan2(-r20, std::hypot(r00, r10)), std::atan2(r10, r00)};
}

}  // namespace

std::string cube_body_name(CubeColor color, int index) {
  return fmt::format("cube_{}_{}", color_name(color), index);
}

GripperGeometry gripper_geometry(const RobotModel& model) {
  const double cube = model.scene.cube_size_m;
  GripperGeometry g;
  g.closed_gap_m = cube + 0.001;
  g.open_travel_m = 0.4 * cube;
  g.finger_depth_m = 0.8 * cube;
  g.finger_height_m = 1.2 * cube;
  return g;
}

namespace {

// The arm's parts across its centre line (m): the carriage box's half width, the links'
// capsule radii, the palm box's half extents along the gripper's x and y axes.
constexpr double kCarriageHalfWidthM = 0.022;
constexpr double kLink1RadiusM = 0.018;
constexpr double kLink2RadiusM = 0.015;
double palm_half_x_m(const GripperGeometry& g) {
  return 0.5 * g.closed_gap_m + g.open_travel_m + 0.008;
}
double palm_half_y_m(const GripperGeometry& g) { return 0.6 * g.finger_depth_m; }

}  // namespace

double arm_half_width_m(const RobotModel& model) {
  const GripperGeometry g = gripper_geometry(model);
  return std::max({kCarriageHalfWidthM, kLink1RadiusM, kLink2RadiusM,
                   std::hypot(palm_half_x_m(g), palm_half_y_m(g)),
                   kFlagOffsetM + kFlagMarkerRadiusM});
}

namespace {

// The options and the camera, checked before anything is written.
Status check_options(const SceneModel& sc, const MjcfOptions& o) {
  if (o.cubes_per_color < 1 || o.cubes_per_color > 64) {
    return bad_option(
        fmt::format("cubes_per_color = {}: must be between 1 and 64", o.cubes_per_color));
  }
  if (!(o.timestep_s >= 1e-4 && o.timestep_s <= 0.01)) {
    return bad_option(fmt::format("timestep_s = {}: must be in [0.0001, 0.01] s", o.timestep_s));
  }
  const CameraModel& cam = sc.camera;
  const int off_w = o.offscreen_width_px > 0 ? o.offscreen_width_px : cam.width_px;
  const int off_h = o.offscreen_height_px > 0 ? o.offscreen_height_px : cam.height_px;
  if (off_w < 1 || off_h < 1 || off_w > 4096 || off_h > 4096) {
    return bad_option(
        fmt::format("offscreen size {}x{}: must be 1..4096 pixels each way", off_w, off_h));
  }
  if (!(o.cube_mass_kg > 0.0)) {
    return bad_option(fmt::format("cube_mass_kg = {}: must be > 0", o.cube_mass_kg));
  }
  const Vec3 forward = sub(cam.look_at_m, cam.pos_m);
  if (!(norm(forward) > 1e-6)) return bad_option("scene.camera: pos_m and look_at_m coincide");
  if (!(cam.fovy_deg > 1.0 && cam.fovy_deg < 179.0)) {
    return bad_option(fmt::format("scene.camera.fovy_deg = {}: must be in (1, 179)", cam.fovy_deg));
  }
  return Ok{};
}

// From <mujoco> to the end of <default> (options checked).
std::string header(const std::string& name, const SceneModel& sc, const MjcfOptions& o) {
  const CameraModel& cam = sc.camera;
  const int off_w = o.offscreen_width_px > 0 ? o.offscreen_width_px : cam.width_px;
  const int off_h = o.offscreen_height_px > 0 ? o.offscreen_height_px : cam.height_px;
  std::string x;
  x += fmt::format("<mujoco model=\"{}\">\n", name);
  x += "  <compiler angle=\"radian\" inertiafromgeom=\"true\"/>\n";
  x += fmt::format(
      "  <option timestep=\"{}\" integrator=\"Euler\" gravity=\"0 0 -9.81\" "
      "cone=\"pyramidal\"/>\n",
      num(o.timestep_s));
  // extent fixed so that the parked cubes far away do not move the clipping planes
  x += "  <statistic extent=\"0.6\" center=\"0.1 0 0\"/>\n";
  x += fmt::format(
      "  <visual>\n    <global offwidth=\"{}\" offheight=\"{}\"/>\n"
      "    <quality shadowsize=\"2048\" offsamples=\"0\"/>\n"
      "    <map znear=\"0.02\" zfar=\"20\"/>\n"
      "    <headlight ambient=\"0.3 0.3 0.3\" diffuse=\"0.3 0.3 0.3\" specular=\"0 0 0\"/>\n"
      "  </visual>\n"
      "  <asset>\n    <material name=\"matte\" specular=\"0.1\" shininess=\"0.1\"/>\n",
      off_w, off_h);
  if (o.pattern) {
    x += fmt::format(
        "    <texture name=\"pattern\" type=\"2d\" file=\"{}\"/>\n"
        "    <material name=\"pattern\" texture=\"pattern\" texrepeat=\"1 1\" "
        "texuniform=\"false\" specular=\"0\" shininess=\"0\" reflectance=\"0\"/>\n",
        kPatternTextureFile);
  }
  x += "  </asset>\n";
  x += "  <default>\n"
       "    <geom contype=\"0\" conaffinity=\"0\" material=\"matte\" rgba=\"0.82 0.82 0.85 1\"/>\n"
       "    <default class=\"solid\"><geom contype=\"1\" conaffinity=\"1\" condim=\"3\" "
       "friction=\"0.8 0.005 0.0001\"/></default>\n"
       "  </default>\n";
  return x;
}

// The light and the table (a box of half sizes `half` centred at `centre` in the plane, its
// top at table_z_m).
constexpr double kTableHalfT = 0.01;
// One robot's table in its base frame: covers its workspace and the trays.
constexpr double kTableHalfX = 0.3, kTableHalfY = 0.32, kTableCentreX = 0.08;
std::string light_and_table(const SceneModel& sc, double cx, double cy, double hx, double hy) {
  std::string x;
  x += "    <light name=\"sun\" pos=\"0.1 0 1.2\" dir=\"0 0 -1\" directional=\"true\" "
       "diffuse=\"0.45 0.45 0.45\" specular=\"0.1 0.1 0.1\" castshadow=\"true\"/>\n";
  x += fmt::format(
      "    <geom name=\"table\" class=\"solid\" type=\"box\" size=\"{}\" pos=\"{}\" "
      "rgba=\"0.72 0.68 0.6 1\"/>\n",
      vec(hx, hy, kTableHalfT), vec(cx, cy, sc.table_z_m - kTableHalfT));
  return x;
}

// The robot's foot and column, in its base frame: from the table to above the highest
// carriage position. `p` prefixes the names, `ind` indents the lines.
std::string column(const RobotModel& model, const std::string& p, const std::string& ind) {
  const SceneModel& sc = model.scene;
  const double col_top = model.limits[0].max + model.dh[0].d_m + 0.04;
  const double col_h = 0.5 * (col_top - sc.table_z_m);
  std::string x;
  x += fmt::format(
      "{}<geom name=\"{}base\" type=\"cylinder\" size=\"0.055 0.006\" pos=\"{}\" "
      "rgba=\"0.25 0.25 0.28 1\"/>\n",
      ind, p, vec(0, 0, sc.table_z_m + 0.006));
  x += fmt::format(
      "{}<geom name=\"{}column\" type=\"box\" size=\"{}\" pos=\"{}\" rgba=\"0.3 0.3 0.33 1\"/>\n",
      ind, p, vec(0.016, 0.016, col_h), vec(-0.03, 0, sc.table_z_m + col_h));
  return x;
}

// Trays, pattern and camera, in the world frame.
std::string scene_objects(const SceneModel& sc, const MjcfOptions& o) {
  const CameraModel& cam = sc.camera;
  std::string x;
  // sorting trays: a floor and four walls around the inner square
  for (int c = 0; c < kNumColors; ++c) {
    const Tray& t = sc.trays[c];
    const double wall = 0.003, h = 0.006, half = t.size_m / 2;
    x += fmt::format("    <body name=\"tray_{}\" pos=\"{}\">\n", color_name(CubeColor(c)),
                     vec(t.x_m, t.y_m, sc.table_z_m));
    const std::string rgba = kTrayRgba[c];
    x += fmt::format(
        "      <geom class=\"solid\" type=\"box\" size=\"{}\" pos=\"0 0 0.001\" rgba=\"{}\"/>\n",
        vec(half + wall, half + wall, 0.001), rgba);
    for (int side = 0; side < 4; ++side) {
      const bool along_x = side < 2;
      const double s = (side % 2 == 0) ? 1.0 : -1.0;
      const Vec3 size = along_x ? Vec3{half + 2 * wall, wall, h} : Vec3{wall, half, h};
      const Vec3 pos = along_x ? Vec3{0, s * (half + wall), h} : Vec3{s * (half + wall), 0, h};
      x += fmt::format(
          "      <geom class=\"solid\" type=\"box\" size=\"{}\" pos=\"{}\" rgba=\"{}\"/>\n",
          vec(size[0], size[1], size[2]), vec(pos[0], pos[1], pos[2]), rgba);
    }
    x += "    </body>\n";
  }
  // the printed pattern: a sheet lying on the table, its surface thickness_m above it
  if (o.pattern) {
    const PatternModel& p = sc.pattern;
    const auto size = pattern_sheet_size_m(p);
    x += fmt::format(
        "    <geom name=\"{}\" type=\"box\" size=\"{}\" pos=\"{}\" euler=\"0 0 {}\" "
        "material=\"pattern\" rgba=\"1 1 1 1\"/>\n",
        kPatternGeom, vec(0.5 * size[0], 0.5 * size[1], 0.5 * p.thickness_m),
        vec(p.x_m, p.y_m, sc.table_z_m + 0.5 * p.thickness_m), num(p.yaw_rad));
  }
  // overhead camera: looks along -z of its frame, x to the right of the image, y up
  {
    const CameraAxes axes = camera_axes(cam);
    const Vec3& cx = axes.x;
    const Vec3& cy = axes.y;
    x += fmt::format(
        "    <camera name=\"{}\" mode=\"fixed\" pos=\"{}\" xyaxes=\"{} {}\" fovy=\"{}\"/>\n",
        kCameraName, vec(cam.pos_m[0], cam.pos_m[1], cam.pos_m[2]), vec(cx[0], cx[1], cx[2]),
        vec(cy[0], cy[1], cy[2]), num(cam.fovy_deg));
  }
  return x;
}

// The arm: one body per DH row. Body i sits in frame i-1; its joint moves about (along) the
// local z axis; its child sits at Tz(d_i) Tx(a_i) Rx(alpha_i) Rz(theta_{i+1}). `p` prefixes
// the names, `ind` indents the outermost body.
std::string arm(const RobotModel& model, const std::string& p, const std::string& ind) {
  const auto& dh = model.dh;
  const GripperGeometry grip = gripper_geometry(model);
  const auto in = [&ind](int level) { return ind + std::string(2 * level, ' '); };
  std::string x;
  const std::string arm_rgba = "0.93 0.93 0.95 1";
  x += fmt::format("{}<body name=\"{}carriage\" pos=\"{}\" quat=\"{}\">\n", in(0), p,
                   vec(0, 0, dh[0].d_m), quat_xz(0.0, dh[0].theta_rad));
  x += fmt::format(
      "{}<joint name=\"{}j1\" type=\"slide\" axis=\"0 0 1\" limited=\"false\" range=\"{} {}\" "
      "damping=\"120\" armature=\"0.05\"/>\n",
      in(1), p, num(model.limits[0].min), num(model.limits[0].max));
  x += fmt::format("{}<geom type=\"box\" size=\"{}\" pos=\"{}\" mass=\"0.35\" rgba=\"{}\"/>\n",
                   in(1), vec(0.5 * dh[0].a_m + 0.02, kCarriageHalfWidthM, 0.012),
                   vec(0.5 * dh[0].a_m - 0.02, 0, 0), arm_rgba);
  x += fmt::format("{}<body name=\"{}link1\" pos=\"{}\" quat=\"{}\">\n", in(1), p,
                   vec(dh[0].a_m, 0, 0), quat_xz(dh[0].alpha_rad, dh[1].theta_rad));
  x += fmt::format(
      "{}<joint name=\"{}j2\" type=\"hinge\" axis=\"0 0 1\" limited=\"false\" "
      "damping=\"0.8\" armature=\"0.002\"/>\n",
      in(2), p);
  x += fmt::format(
      "{}<geom type=\"capsule\" fromto=\"0 0 0 {}\" size=\"{}\" mass=\"0.2\" "
      "rgba=\"{}\"/>\n",
      in(2), vec(dh[1].a_m, 0, 0), fmt::format("{}", kLink1RadiusM), arm_rgba);
  x += fmt::format(
      "{}<geom type=\"cylinder\" fromto=\"{} {}\" size=\"0.012\" mass=\"0.01\" "
      "rgba=\"0.3 0.3 0.33 1\"/>\n",
      in(2), vec(dh[1].a_m, 0, 0.0), vec(dh[1].a_m, 0, dh[1].d_m - 0.001));
  x += fmt::format("{}<body name=\"{}link2\" pos=\"{}\" quat=\"{}\">\n", in(2), p,
                   vec(dh[1].a_m, 0, dh[1].d_m), quat_xz(dh[1].alpha_rad, dh[2].theta_rad));
  x += fmt::format(
      "{}<joint name=\"{}j3\" type=\"hinge\" axis=\"0 0 1\" limited=\"false\" "
      "damping=\"0.3\" armature=\"0.001\"/>\n",
      in(3), p);
  x += fmt::format(
      "{}<geom type=\"capsule\" fromto=\"0 0 0 {}\" size=\"{}\" mass=\"0.15\" "
      "rgba=\"{}\"/>\n",
      in(3), vec(dh[2].a_m, 0, 0), fmt::format("{}", kLink2RadiusM), arm_rgba);
  x += fmt::format("{}<body name=\"{}{}\" pos=\"{}\" quat=\"{}\">\n", in(3), p, kGripperBody,
                   vec(dh[2].a_m, 0, dh[2].d_m), quat_xz(dh[2].alpha_rad, dh[3].theta_rad));
  x += fmt::format(
      "{}<joint name=\"{}j4\" type=\"hinge\" axis=\"0 0 1\" limited=\"false\" "
      "damping=\"0.02\" armature=\"0.0005\"/>\n",
      in(4), p);
  // wrist: a servo horn down to the palm just above the fingers
  const double tool_z = dh[3].d_m;  // tool (grasp point) z in the wrist body frame
  const double palm_z = tool_z + 0.5 * grip.finger_height_m + 0.004;
  x += fmt::format(
      "{}<geom type=\"cylinder\" fromto=\"0 0 0.004 {}\" size=\"0.008\" mass=\"0.04\" "
      "rgba=\"0.3 0.3 0.33 1\"/>\n",
      in(4), vec(dh[3].a_m, 0, palm_z));
  x += fmt::format("{}<geom type=\"box\" size=\"{}\" pos=\"{}\" mass=\"0.02\" rgba=\"{}\"/>\n",
                   in(4), vec(palm_half_x_m(grip), palm_half_y_m(grip), 0.004),
                   vec(dh[3].a_m, 0, palm_z), arm_rgba);
  x += fmt::format(
      "{}<site name=\"{}{}\" pos=\"{}\" quat=\"{}\" size=\"0.003\" "
      "rgba=\"1 0.6 0 0.6\"/>\n",
      in(4), p, kToolSite, vec(dh[3].a_m, 0, tool_z), quat_xz(dh[3].alpha_rad, 0.0));
  // the tracking marker: a magenta disc on the wrist axis, above the elbow link's end, where
  // the overhead camera sees it at every pose
  x += fmt::format(
      "{}<geom name=\"{}{}\" type=\"cylinder\" size=\"{} 0.0001\" pos=\"0 0 {}\" "
      "mass=\"0.001\" rgba=\"1 0 1 1\"/>\n",
      in(4), p, kMarkerGeom, num(kMarkerRadiusM), num(marker_above_wrist_m(model)));
  // the flag: a thin bracket from the wrist axis out along the gripper's x axis, carrying the
  // cyan disc at the magenta one's height
  {
    const double h = marker_above_wrist_m(model);
    const double from = kMarkerRadiusM, to = kFlagOffsetM - kFlagMarkerRadiusM;
    x += fmt::format(
        "{}<geom type=\"box\" size=\"{}\" pos=\"{}\" mass=\"0.0005\" "
        "rgba=\"0.3 0.3 0.33 1\"/>\n",
        in(4), vec(0.5 * (to - from) + 0.001, 0.0015, 0.0004),
        vec(0.5 * (from + to), 0, h - 0.0009));
    x += fmt::format(
        "{}<geom name=\"{}{}\" type=\"cylinder\" size=\"{} 0.0001\" pos=\"{}\" "
        "mass=\"0.0005\" rgba=\"0 1 1 1\"/>\n",
        in(4), p, kFlagMarkerGeom, num(kFlagMarkerRadiusM), vec(kFlagOffsetM, 0, h));
  }
  // fingers: slide along the wrist x axis; joint value = extra opening beyond closed
  for (int side = 0; side < 2; ++side) {
    const double s = side == 0 ? 1.0 : -1.0;
    const double finger_t = 0.0025;
    x += fmt::format("{}<body name=\"{}finger_{}_body\" pos=\"{}\">\n", in(4), p,
                     side == 0 ? "l" : "r",
                     vec(dh[3].a_m + s * (0.5 * grip.closed_gap_m + finger_t), 0, tool_z));
    x += fmt::format(
        "{}<joint name=\"{}{}\" type=\"slide\" axis=\"{}\" limited=\"true\" "
        "range=\"0 {}\" damping=\"1\" armature=\"0.01\"/>\n",
        in(5), p, kFingerJoints[side], vec(s, 0, 0), num(grip.open_travel_m));
    x += fmt::format(
        "{}<geom type=\"box\" size=\"{}\" pos=\"{}\" mass=\"0.005\" "
        "rgba=\"0.2 0.2 0.22 1\"/>\n",
        in(5), vec(finger_t, 0.5 * grip.finger_depth_m, 0.5 * grip.finger_height_m),
        vec(0, 0, 0.1 * grip.finger_height_m));
    x += in(4) + "</body>\n";
  }
  x += in(3) + "</body>\n" + in(2) + "</body>\n" + in(1) + "</body>\n" + in(0) + "</body>\n";
  return x;
}

// The cube pool, parked far from the scene (the simulator disables their contacts while
// parked).
std::string cubes(const SceneModel& sc, const MjcfOptions& o) {
  const double cube = sc.cube_size_m;
  std::string x;
  for (int c = 0; c < kNumColors; ++c) {
    for (int i = 0; i < o.cubes_per_color; ++i) {
      const int k = c * o.cubes_per_color + i;
      x += fmt::format(
          "    <body name=\"{}\" pos=\"{}\">\n      <freejoint/>\n"
          "      <geom class=\"solid\" type=\"box\" size=\"{}\" mass=\"{}\" rgba=\"{}\"/>\n"
          "    </body>\n",
          cube_body_name(CubeColor(c), i), vec(5.0 + 0.1 * k, 5.0, 0.0),
          vec(cube / 2, cube / 2, cube / 2), num(o.cube_mass_kg), kCubeRgba[c]);
    }
  }
  return x;
}

// One weld per cube between the robot's gripper and the cube, inactive until a grasp.
std::string welds(const std::string& p, const MjcfOptions& o) {
  std::string x;
  for (int c = 0; c < kNumColors; ++c) {
    for (int i = 0; i < o.cubes_per_color; ++i) {
      x += fmt::format(
          "    <weld name=\"{2}hold_{0}\" body1=\"{2}{1}\" body2=\"{0}\" active=\"false\" "
          "solref=\"0.01 1\"/>\n",
          cube_body_name(CubeColor(c), i), kGripperBody, p);
    }
  }
  return x;
}

// Position servos for the simulate mode; gains sized for the link inertias of arm().
std::string actuators(const RobotModel& model, const std::string& p) {
  const GripperGeometry grip = gripper_geometry(model);
  std::string x;
  static constexpr const char* kJ[] = {"j1", "j2", "j3", "j4"};
  static constexpr double kKp[] = {4000.0, 40.0, 15.0, 1.0};
  for (int j = 0; j < kNumJoints; ++j) {
    x += fmt::format(
        "    <position name=\"{4}{0}\" joint=\"{4}{0}\" kp=\"{1}\" ctrllimited=\"true\" "
        "ctrlrange=\"{2} {3}\"/>\n",
        kJ[j], num(kKp[j]), num(model.limits[j].min), num(model.limits[j].max), p);
  }
  for (int side = 0; side < 2; ++side) {
    x += fmt::format(
        "    <position name=\"{2}{0}\" joint=\"{2}{0}\" kp=\"20\" ctrllimited=\"true\" "
        "ctrlrange=\"0 {1}\"/>\n",
        kFingerJoints[side], num(grip.open_travel_m), p);
  }
  return x;
}

}  // namespace

Result<std::string> make_mjcf(const RobotModel& model, const MjcfOptions& o) {
  if (Status s = check_options(model.scene, o); !s) return s.error();
  const SceneModel& sc = model.scene;
  std::string x;
  x.reserve(16384);
  x += header(model.name, sc, o);
  x += "  <worldbody>\n";
  x += light_and_table(sc, kTableCentreX, 0.0, kTableHalfX, kTableHalfY);
  x += column(model, "", "    ");
  x += scene_objects(sc, o);
  x += arm(model, "", "    ");
  x += cubes(sc, o);
  x += "  </worldbody>\n";
  x += "  <equality>\n" + welds("", o) + "  </equality>\n";
  x += "  <actuator>\n" + actuators(model, "") + "  </actuator>\n</mujoco>\n";
  return x;
}

Result<std::string> make_mjcf(const Workcell& workcell, const MjcfOptions& o) {
  if (Status s = validate(workcell); !s) return s.error();
  if (workcell.robots.size() == 1) {
    // the paper's setup: exactly the single robot's model (its base frame is the world's)
    RobotModel m = workcell.robots[0].model;
    m.scene = workcell.scene;
    return make_mjcf(m, o);
  }
  const SceneModel& sc = workcell.scene;
  if (Status s = check_options(sc, o); !s) return s.error();
  // the table covers every robot's own table, turned with its base
  double lo_x = INFINITY, hi_x = -INFINITY, lo_y = INFINITY, hi_y = -INFINITY;
  for (const RobotInstance& r : workcell.robots) {
    for (const double sx : {-1.0, 1.0}) {
      for (const double sy : {-1.0, 1.0}) {
        const Vec3 c =
            base_to_world(r.base, {kTableCentreX + sx * kTableHalfX, sy * kTableHalfY, 0.0});
        lo_x = std::min(lo_x, c[0]);
        hi_x = std::max(hi_x, c[0]);
        lo_y = std::min(lo_y, c[1]);
        hi_y = std::max(hi_y, c[1]);
      }
    }
  }
  std::string x;
  x.reserve(16384 * workcell.robots.size());
  x += header("workcell", sc, o);
  x += "  <worldbody>\n";
  x += light_and_table(sc, 0.5 * (lo_x + hi_x), 0.5 * (lo_y + hi_y), 0.5 * (hi_x - lo_x),
                       0.5 * (hi_y - lo_y));
  x += scene_objects(sc, o);
  for (int i = 0; i < static_cast<int>(workcell.robots.size()); ++i) {
    const RobotInstance& r = workcell.robots[i];
    const RobotModel m = scene_in_base(workcell, i);
    const std::string p = r.name + "/";
    x += fmt::format("    <body name=\"{}base_frame\" pos=\"{}\" quat=\"{}\">\n", p,
                     vec(r.base.x_m, r.base.y_m, r.base.z_m), quat_xz(0.0, r.base.yaw_rad));
    x += column(m, p, "      ");
    x += arm(m, p, "      ");
    x += "    </body>\n";
  }
  x += cubes(sc, o);
  x += "  </worldbody>\n";
  x += "  <equality>\n";
  for (const RobotInstance& r : workcell.robots) x += welds(r.name + "/", o);
  x += "  </equality>\n";
  x += "  <actuator>\n";
  for (int i = 0; i < static_cast<int>(workcell.robots.size()); ++i) {
    x += actuators(scene_in_base(workcell, i), workcell.robots[i].name + "/");
  }
  x += "  </actuator>\n</mujoco>\n";
  return x;
}

namespace {

// The arm's links and joints (base_link ... tool), names prefixed with `p`.
std::string urdf_arm(const RobotModel& model, const std::string& p) {
  const auto& dh = model.dh;
  std::string x;
  static constexpr const char* kLinks[] = {"base_link", "carriage", "link1",
                                           "link2",     "wrist",    "tool"};
  static constexpr const char* kJ[] = {"j1", "j2", "j3", "j4"};
  for (const char* l : kLinks) x += fmt::format("  <link name=\"{}{}\"/>\n", p, l);
  // joint i+1 sits at Tz(d_i) Tx(a_i) Rx(alpha_i) Rz(theta_{i+1}) of the previous link
  Vec3 xyz{0, 0, dh[0].d_m};
  Vec3 rpy = rpy_xz(0.0, dh[0].theta_rad);
  for (int j = 0; j < kNumJoints; ++j) {
    const bool prismatic = j == 0;
    x += fmt::format(
        "  <joint name=\"{0}{1}\" type=\"{2}\">\n    <parent link=\"{0}{3}\"/>\n"
        "    <child link=\"{0}{4}\"/>\n"
        "    <origin xyz=\"{5}\" rpy=\"{6}\"/>\n    <axis xyz=\"0 0 1\"/>\n"
        "    <limit lower=\"{7}\" upper=\"{8}\" effort=\"50\" velocity=\"{9}\"/>\n  </joint>\n",
        p, kJ[j], prismatic ? "prismatic" : "revolute", kLinks[j], kLinks[j + 1],
        vec(xyz[0], xyz[1], xyz[2]), vec(rpy[0], rpy[1], rpy[2]), num(model.limits[j].min),
        num(model.limits[j].max), prismatic ? "0.05" : "3.0");
    const double next_theta = j + 1 < kNumJoints ? dh[j + 1].theta_rad : 0.0;
    xyz = {dh[j].a_m, 0.0, j == 0 ? 0.0 : dh[j].d_m};
    rpy = rpy_xz(dh[j].alpha_rad, next_theta);
  }
  // the tool frame, fixed to the wrist
  x += fmt::format(
      "  <joint name=\"{0}tool_fixed\" type=\"fixed\">\n    <parent link=\"{0}wrist\"/>\n"
      "    <child link=\"{0}tool\"/>\n    <origin xyz=\"{1}\" rpy=\"{2}\"/>\n  </joint>\n",
      p, vec(dh[3].a_m, 0, dh[3].d_m), vec(rpy[0], rpy[1], rpy[2]));
  return x;
}

}  // namespace

Result<std::string> make_urdf(const RobotModel& model) {
  if (Status s = validate(model); !s) return s.error();
  std::string x;
  x += fmt::format("<?xml version=\"1.0\"?>\n<robot name=\"{}\">\n", model.name);
  x += urdf_arm(model, "");
  x += "</robot>\n";
  return x;
}

Result<std::string> make_urdf(const Workcell& workcell) {
  if (Status s = validate(workcell); !s) return s.error();
  if (workcell.robots.size() == 1) return make_urdf(workcell.robots[0].model);
  std::string x = "<?xml version=\"1.0\"?>\n<robot name=\"workcell\">\n  <link name=\"world\"/>\n";
  for (const RobotInstance& r : workcell.robots) {
    const std::string p = r.name + "/";
    x += urdf_arm(r.model, p);
    x += fmt::format(
        "  <joint name=\"{0}base_fixed\" type=\"fixed\">\n    <parent link=\"world\"/>\n"
        "    <child link=\"{0}base_link\"/>\n    <origin xyz=\"{1}\" rpy=\"{2}\"/>\n  </joint>\n",
        p, vec(r.base.x_m, r.base.y_m, r.base.z_m), vec(0, 0, r.base.yaw_rad));
  }
  x += "</robot>\n";
  return x;
}

double marker_above_wrist_m(const RobotModel& model) {
  // on top of the elbow link's rounded end (radius 15 mm), which sits -d3 above the wrist
  return -model.dh[2].d_m + 0.0155;
}

namespace {

// The wrist axis's position in the base plane and the heading of the gripper's x axis, along
// the body chain of make_mjcf() (the DH rows with their theta offsets).
struct WristPlanar {
  double x = 0.0, y = 0.0, heading = 0.0;
};
WristPlanar wrist_planar(const RobotModel& model, const JointVector& q) {
  const auto& dh = model.dh;
  WristPlanar w;
  double h = dh[0].theta_rad;
  w.x = dh[0].a_m * std::cos(h);
  w.y = dh[0].a_m * std::sin(h);
  for (int i = 1; i <= 2; ++i) {
    h += dh[i].theta_rad + q[i];
    w.x += dh[i].a_m * std::cos(h);
    w.y += dh[i].a_m * std::sin(h);
  }
  w.heading = h + dh[3].theta_rad + q[3];
  return w;
}

}  // namespace

std::array<double, 3> marker_position(const RobotModel& model, const JointVector& q) {
  const auto& dh = model.dh;
  const WristPlanar w = wrist_planar(model, q);
  const double z = q[0] + dh[0].d_m + dh[1].d_m + dh[2].d_m + marker_above_wrist_m(model);
  return {w.x, w.y, z};
}

std::array<double, 3> flag_marker_position(const RobotModel& model, const JointVector& q) {
  const WristPlanar w = wrist_planar(model, q);
  const std::array<double, 3> m = marker_position(model, q);
  return {w.x + kFlagOffsetM * std::cos(w.heading), w.y + kFlagOffsetM * std::sin(w.heading), m[2]};
}

}  // namespace scaratwin::sim
