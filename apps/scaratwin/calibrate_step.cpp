#include "calibrate_step.hpp"

#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <numbers>
#include <thread>

#include <fmt/format.h>
#include <Eigen/Dense>
#include <Eigen/Geometry>

#include "scaratwin/core/units.hpp"
#include "scaratwin/hub/report.hpp"
#include "scaratwin/kinematics/kinematics.hpp"
#include "scaratwin/plant/plant.hpp"
#include "scaratwin/trajectory/trajectory.hpp"
#include "scaratwin/vision/webcam.hpp"

namespace scaratwin::cli {
namespace {

using namespace std::chrono_literals;
constexpr double kDeg = std::numbers::pi / 180.0;

std::string utc_now() {
  const std::time_t t = std::time(nullptr);
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%SZ", std::gmtime(&t));
  return buf;
}

double distance(const std::array<double, 3>& a, const std::array<double, 3>& b) {
  return std::hypot(a[0] - b[0], a[1] - b[1], a[2] - b[2]);
}

}  // namespace

Status EmulatedOperator::pattern(bool on) { return side_.pattern(on); }

Status EmulatedOperator::touch_off(Hub& hub, const std::string& name,
                                   const std::array<double, 3>& mark) {
  // look, nudge the tool towards the mark, look again: until it is on it as well as the
  // robot's steps allow
  double best = 1e9;
  for (int i = 0; i < 10; ++i) {
    if (Status s = hub.sleep(0.2); !s) return s;
    auto t = side_.query();
    if (!t) return t.error();
    const std::array<double, 3> tool{t->tool[0], t->tool[1], t->tool[2]};
    const double off = distance(tool, mark);
    if (off < 0.08e-3 || (off > 0.9 * best && off < 0.3e-3)) return Ok{};
    best = std::min(best, off);
    auto now = hub.fresh_physical(2.0);
    if (!now) return now.error();
    const Eigen::Matrix4d jac = jacobian(hub.model(), now->q);
    const Eigen::Vector3d e(mark[0] - tool[0], mark[1] - tool[1], mark[2] - tool[2]);
    const Eigen::Vector3d dq = jac.block<3, 3>(0, 0).colPivHouseholderQr().solve(e);
    JointVector target = now->q;
    for (int j = 0; j < 3; ++j) target[j] += dq[j];
    // each nudge ends slowly from the same side, so the belts rest on one flank
    if (Status s = approach(hub, target, {1, 1, 1}); !s) return s;
  }
  return Error{1, fmt::format("touch-off {}: the tool did not come within 0.3 mm of the mark "
                              "(closest {:.2f} mm)",
                              name, best * 1e3)};
}

Status TerminalOperator::pattern(bool on) {
  std::fputs(on ? "    lay the printed pattern on the table (registered to the robot's base) "
                  "and press Enter: "
                : "    take the pattern away and press Enter: ",
             stdout);
  std::fflush(stdout);
  std::string line;
  if (!std::getline(std::cin, line)) return Error{1, "calibration: no operator at the terminal"};
  return Ok{};
}

Status TerminalOperator::touch_off(Hub& hub, const std::string& name,
                                   const std::array<double, 3>& mark) {
  fmt::print(
      "    touch-off {} at ({:.1f}, {:.1f}, {:.1f}) mm: jog with x+ x- y+ y- z+ z- and a step "
      "in steps (e.g. `y+ 3`), Enter alone when the tool is on the mark\n",
      name, mark[0] * 1e3, mark[1] * 1e3, mark[2] * 1e3);
  for (;;) {
    fmt::print("    > ");
    std::fflush(stdout);
    std::string line;
    if (!std::getline(std::cin, line)) return Error{1, "calibration: no operator at the terminal"};
    if (line.empty()) return Ok{};
    char axis = 0, sign = 0;
    int steps = 1;
    if (std::sscanf(line.c_str(), " %c%c %d", &axis, &sign, &steps) < 2 ||
        (sign != '+' && sign != '-') || steps < 1 || steps > 200) {
      fmt::print("    expected e.g. `z- 5`\n");
      continue;
    }
    const protocol::Axis a = axis == 'z'   ? protocol::Axis::kZ
                             : axis == 'y' ? protocol::Axis::kJ2
                                           : protocol::Axis::kJ3;
    if (Status s = hub.jog(a, sign == '+' ? steps : -steps); !s) return s;
    (void)hub.wait_idle(10.0);
  }
}

std::filesystem::path default_overlay_path(const std::filesystem::path& base) {
  std::filesystem::path p = base;
  p.replace_extension();
  return p.string() + ".calibrated.toml";
}

Result<CalibrationRun> calibrate_and_write(Hub& hub, NetCamera& camera, CalibrationOperator& op,
                                           const std::filesystem::path& base_config,
                                           const std::filesystem::path& overlay,
                                           const CalibrationOptions& options) {
  auto run = calibrate(hub, camera, op, options);
  if (!run) return run.error();
  const calib::Fit& f = run->fit;
  fmt::print("    {:<22} {:>12} {:>10}\n", "parameter", "identified", "std error");
  for (int i = 0; i < calib::kParamCount; ++i) {
    const auto& info = calib::param_info(i);
    fmt::print("    {:<22} {:>12.4f} {:>10.4f}\n", info.key, f.value[i] / info.to_si,
               f.std_error[i] / info.to_si);
  }
  fmt::print(
      "    from {} pattern corners, {} marker views, {} touch-offs: residual {:.2f} px (markers "
      "{:.2f} px), touch-offs {:.3f} mm; fit {:.0f} ms; routine {:.0f} s of robot time, {} "
      "pictures\n",
      f.pattern_points, f.marker_views, f.touch_offs, f.pixel_rms, f.marker_rms_px,
      f.touch_rms_m * 1e3, f.fit_seconds * 1e3, run->robot_s, run->pictures);
  // the base as the overlay names it: relative to the overlay's folder
  std::error_code ec;
  const std::filesystem::path dir = std::filesystem::absolute(overlay).parent_path();
  std::filesystem::path ref =
      std::filesystem::relative(std::filesystem::absolute(base_config), dir, ec);
  if (ec || ref.empty()) ref = std::filesystem::absolute(base_config);
  const std::string text = calib::overlay_text(hub.model(), f, ref.string(), utc_now());
  const std::filesystem::path tmp = overlay.string() + ".tmp";
  {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    out << text;
    if (!out) return Error{1, "calibration: cannot write " + tmp.string()};
  }
  std::filesystem::rename(tmp, overlay, ec);
  if (ec) return Error{1, "calibration: cannot write " + overlay.string() + ": " + ec.message()};
  fmt::print("    calibrated description: {} (load it with --config)\n", overlay.string());
  return run;
}

std::vector<ToolPose> test_poses(const RobotModel& model, int count, std::uint64_t seed) {
  std::vector<ToolPose> out;
  std::uint64_t s = seed * 0x9E3779B97F4A7C15ULL + 12345;
  auto uni = [&s](double lo, double hi) { return seeded_uniform(s, lo, hi); };
  const double table = model.scene.table_z_m;
  int tries = 0;
  while (static_cast<int>(out.size()) < count && tries++ < 100000) {
    // around the J2 axis, within reach; the jaws clear of the trays' walls
    const double r = uni(0.09, 0.175), a = uni(-1.3, 1.3);
    ToolPose p{model.dh[0].a_m + r * std::cos(a), r * std::sin(a), uni(table + 0.035, table + 0.08),
               uni(20 * kDeg, 160 * kDeg)};
    auto q = inverse(model, p, model.home);
    if (!q) continue;
    if (first_joint_outside_limits(model, *q) >= 0) continue;
    out.push_back(p);
  }
  return out;
}

Result<std::vector<double>> measure_test_poses(Hub& hub, EmulatorSide& side,
                                               const std::vector<ToolPose>& poses) {
  std::vector<double> out;
  for (const ToolPose& p : poses) {
    auto now = hub.fresh_physical(2.0);
    if (!now) return now.error();
    auto q = inverse(hub.model(), p, now->q);
    if (!q) return q.error();
    if (Status s = approach(hub, *q, {1, 1, 1}); !s) return s.error();
    if (Status s = hub.sleep(0.3); !s) return s.error();
    auto ps = hub.fresh_physical(2.0);
    if (!ps) return ps.error();
    auto truth = side.query();
    if (!truth) return truth.error();
    const ToolPose v = forward(hub.model(), ps->q);
    out.push_back(
        distance({v.x_m, v.y_m, v.z_m}, {truth->tool[0], truth->tool[1], truth->tool[2]}));
  }
  return out;
}

Result<CalibrationFigures> calibration_phase(Hub& hub, EmulatorSide& side, NetCamera& camera,
                                             const std::filesystem::path& base_config,
                                             const std::filesystem::path& overlay,
                                             std::uint64_t test_seed) {
  const RobotModel base = hub.model();
  const std::vector<ToolPose> poses = test_poses(base, 12, test_seed);
  fmt::print("    before: the robot at {} test poses, the description as it is\n", poses.size());
  auto before = measure_test_poses(hub, side, poses);
  if (!before) return before.error();
  EmulatedOperator op(side);
  CalibrationOptions co;
  co.progress = [](const std::string& line) {
    fmt::print("    {}\n", line);
    std::fflush(stdout);
  };
  auto cal = calibrate_and_write(hub, camera, op, base_config, overlay, co);
  if (!cal) return cal.error();
  hub.set_model(cal->calibrated);
  fmt::print("    after: the same test poses, the calibrated description\n");
  auto after = measure_test_poses(hub, side, poses);
  if (!after) return after.error();
  CalibrationFigures cf;
  cf.before = error_stats(*before);
  cf.after = error_stats(*after);
  cf.test_poses = static_cast<int>(poses.size());
  cf.fit_poses = cal->fit.marker_views + cal->fit.touch_offs;
  cf.robot_s = cal->robot_s;
  cf.fit_s = cal->fit.fit_seconds;
  cf.pixel_rms = cal->fit.pixel_rms;
  cf.overlay = overlay.string();
  const auto truth = true_parameters(base);
  for (int i = 0; i < calib::kParamCount; ++i) {
    const auto& info = calib::param_info(i);
    cf.parameters.push_back({std::string(info.key), cal->fit.value[i] / info.to_si,
                             cal->fit.std_error[i] / info.to_si, truth[i] / info.to_si});
  }
  fmt::print(
      "    virtual -> true tool at {} test poses: before mean {:.2f} p95 {:.2f} max {:.2f} mm; "
      "after mean {:.2f} p95 {:.2f} max {:.2f} mm\n",
      poses.size(), m_to_mm(cf.before.mean_m), m_to_mm(cf.before.p95_m), m_to_mm(cf.before.max_m),
      m_to_mm(cf.after.mean_m), m_to_mm(cf.after.p95_m), m_to_mm(cf.after.max_m));
  hub.record_metric(metric::kCalibBeforeMeanMm, m_to_mm(cf.before.mean_m), "mm");
  hub.record_metric(metric::kCalibBeforeMaxMm, m_to_mm(cf.before.max_m), "mm");
  hub.record_metric(metric::kCalibAfterMeanMm, m_to_mm(cf.after.mean_m), "mm");
  hub.record_metric(metric::kCalibAfterMaxMm, m_to_mm(cf.after.max_m), "mm");
  return cf;
}

std::array<double, calib::kParamCount> true_parameters(const RobotModel& description) {
  using calib::Param;
  const AsBuilt a = draw_as_built(description.physical.as_built);
  std::array<double, calib::kParamCount> t{};
  auto set = [&t](Param p, double v) { t[static_cast<int>(p)] = v; };
  set(Param::kA2, a[AsBuiltParam::kA2]);
  set(Param::kA3, a[AsBuiltParam::kA3]);
  set(Param::kZOffset, a[AsBuiltParam::kZZero]);
  set(Param::kZScale, a[AsBuiltParam::kZLead]);
  set(Param::kJ2Zero, a[AsBuiltParam::kJ2Zero]);
  set(Param::kJ3Zero, a[AsBuiltParam::kJ3Zero]);
  set(Param::kWristOffset, a[AsBuiltParam::kWristOffset]);
  set(Param::kWristGain, a[AsBuiltParam::kWristGain]);
  set(Param::kJawOffset, a[AsBuiltParam::kJawOffset]);
  set(Param::kJ2Backlash, a[AsBuiltParam::kJ2Backlash]);
  set(Param::kJ3Backlash, a[AsBuiltParam::kJ3Backlash]);
  // the camera: the as-built mount against the description's, as the fit's adjustments
  const WebcamModel nominal = nominal_webcam(description.scene.camera);
  const WebcamModel built = nominal_webcam(plant::as_built_robot(description, a).scene.camera);
  for (int i = 0; i < 3; ++i) t[calib::kRobotParams + i] = built.pos_m[i] - nominal.pos_m[i];
  using M = Eigen::Matrix<double, 3, 3, Eigen::RowMajor>;
  const Eigen::Matrix3d rel =
      Eigen::Map<const M>(nominal.r_bc.data()).transpose() * Eigen::Map<const M>(built.r_bc.data());
  const Eigen::AngleAxisd aa(rel);
  const Eigen::Vector3d rv = aa.angle() * aa.axis();
  for (int i = 0; i < 3; ++i) t[calib::kRobotParams + 3 + i] = rv[i];
  set(Param::kCamFocal, 0.0);        // the plant's camera has the description's field of view
  set(Param::kCamK1, std::nan(""));  // its lens is a different model: no single true k1
  return t;
}

}  // namespace scaratwin::cli
