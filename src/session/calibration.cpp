#include "scaratwin/session/calibration.hpp"

#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <numbers>
#include <thread>

#include <fmt/format.h>
#include <Eigen/Dense>
#include <Eigen/Geometry>

#include "scaratwin/config/robot_config.hpp"
#include "scaratwin/core/units.hpp"
#include "scaratwin/hub/report.hpp"
#include "scaratwin/kinematics/kinematics.hpp"
#include "scaratwin/kinematics/motor.hpp"
#include "scaratwin/plant/plant.hpp"
#include "scaratwin/plant/plant_camera.hpp"
#include "scaratwin/session/rig.hpp"
#include "scaratwin/trajectory/trajectory.hpp"
#include "scaratwin/vision/webcam.hpp"
#include "stop_watch.hpp"

namespace scaratwin::session {
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
  // (on within 0.12 mm: about one J2 step at the arm's reach, as well as a person sees it)
  double best = 1e9;
  for (int i = 0; i < 8; ++i) {
    if (Status s = hub.sleep(0.2); !s) return s;
    auto t = side_.query();
    if (!t) return t.error();
    const std::array<double, 3> tool{t->tool[0], t->tool[1], t->tool[2]};
    const double off = distance(tool, mark);
    if (off < 0.12e-3 || (off > 0.9 * best && off < 0.3e-3)) return Ok{};
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
  return Error{CalibrationError::kTouchOff,
               fmt::format("touch-off {}: the tool did not come within 0.3 mm of the mark "
                           "(closest {:.2f} mm)",
                           name, best * 1e3)};
}

std::filesystem::path default_overlay_path(const std::filesystem::path& base) {
  std::filesystem::path p = base;
  p.replace_extension();
  return p.string() + ".calibrated.toml";
}

Result<CalibrationRun> calibrate_and_write(Hub& hub, NetCamera& camera, CalibrationOperator& op,
                                           const std::filesystem::path& base_config,
                                           const std::filesystem::path& overlay,
                                           const CalibrationOptions& options, const Say& say) {
  auto run = calibrate(hub, camera, op, options);
  if (!run) return run.error();
  const calib::Fit& f = run->fit;
  say(fmt::format("    {:<22} {:>12} {:>10}", "parameter", "identified", "std error"));
  for (int i = 0; i < calib::kParamCount; ++i) {
    const auto& info = calib::param_info(i);
    say(fmt::format("    {:<22} {:>12.4f} {:>10.4f}", info.key, f.value[i] / info.to_si,
                    f.std_error[i] / info.to_si));
  }
  say(fmt::format(
      "    from {} pattern corners, {} marker views, {} touch-offs: residual {:.2f} px (markers "
      "{:.2f} px), touch-offs {:.3f} mm; fit {:.0f} ms; routine {:.0f} s of robot time, {} "
      "pictures",
      f.pattern_points, f.marker_views, f.touch_offs, f.pixel_rms, f.marker_rms_px,
      f.touch_rms_m * 1e3, f.fit_seconds * 1e3, run->robot_s, run->pictures));
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
    if (!out)
      return Error{CalibrationError::kWriteFailed, "calibration: cannot write " + tmp.string()};
  }
  std::filesystem::rename(tmp, overlay, ec);
  if (ec)
    return Error{CalibrationError::kWriteFailed,
                 "calibration: cannot write " + overlay.string() + ": " + ec.message()};
  say(fmt::format("    calibrated description: {} (load it with --config)", overlay.string()));
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
    // a margin inside the limits: the calibrated robot's joints for the pose differ a little
    bool inside = true;
    for (int j = 0; j < kNumJoints; ++j) {
      const double margin = j == 0 ? 0.002 : 3.0 * kDeg;
      inside = inside && (*q)[j] >= model.limits[j].min + margin &&
               (*q)[j] <= model.limits[j].max - margin;
    }
    if (!inside) continue;
    out.push_back(p);
  }
  // visited nearest first, one elbow then the other (as the calibration's own poses): the same
  // poses in an order that halves the travel between them
  std::vector<JointVector> joints;
  for (const ToolPose& p : out) joints.push_back(*inverse(model, p, model.home));
  std::vector<ToolPose> ordered;
  for (const JointVector& q : visiting_order(model, joints)) {
    const auto at = std::find(joints.begin(), joints.end(), q);
    ordered.push_back(out[static_cast<std::size_t>(at - joints.begin())]);
  }
  return ordered;
}

Result<TestPoseErrors> measure_test_poses(Hub& hub, EmulatorSide& side,
                                          const std::vector<ToolPose>& poses,
                                          const RobotModel& before) {
  TestPoseErrors out;
  for (const ToolPose& p : poses) {
    // the elbow test_poses() chose (IK seeded at home)
    auto q = inverse(hub.model(), p, hub.model().home);
    if (!q) return q.error();
    if (Status s = approach(hub, *q, {1, 1, 1}); !s) return s.error();
    if (Status s = hub.sleep(0.3); !s) return s.error();
    auto ps = hub.fresh_physical(2.0);
    if (!ps) return ps.error();
    auto truth = side.query();
    if (!truth) return truth.error();
    const std::array<double, 3> true_tool{truth->tool[0], truth->tool[1], truth->tool[2]};
    const auto& steps = ps->raw.steps;
    const JointVector q_before =
        motors_to_joints(before,
                         {static_cast<double>(steps[0]), static_cast<double>(steps[1]),
                          static_cast<double>(steps[2])},
                         rad_to_deg(ps->raw.wrist_rad));
    const ToolPose vb = forward(before, q_before), va = forward(hub.model(), ps->q);
    out.before.push_back(distance({vb.x_m, vb.y_m, vb.z_m}, true_tool));
    out.after.push_back(distance({va.x_m, va.y_m, va.z_m}, true_tool));
  }
  return out;
}

std::vector<CalibrationParameter> compare_parameters(const RobotModel& description,
                                                     const calib::Fit& fit,
                                                     const std::vector<MeasuredJoints>& samples) {
  const auto identified = identified_parameters(description, fit);
  const auto truth = true_parameters(description, samples);
  const auto drawn = drawn_parameters(description);
  std::vector<CalibrationParameter> out;
  for (int i = 0; i < calib::kParamCount; ++i) {
    const auto& info = calib::param_info(i);
    out.push_back({std::string(info.key), identified[i] / info.to_si, fit.std_error[i] / info.to_si,
                   truth[i] / info.to_si, drawn[i] / info.to_si});
  }
  return out;
}

void say_comparison(const std::vector<CalibrationParameter>& params, const Say& say) {
  say("    against the robot as built (the emulator's truth; the camera as the change from the "
      "description's):");
  say(fmt::format("    {:<22} {:>11} {:>9} {:>11} {:>7} {:>11}", "parameter", "identified",
                  "std error", "true", "off/se", "as drawn"));
  for (const CalibrationParameter& p : params) {
    const double z = std::abs(p.identified - p.truth) / p.std_error;
    say(fmt::format("    {:<22} {:>11.4f} {:>9.4f} {:>11.4f} {:>7.1f} {:>11.4f}", p.key,
                    p.identified, p.std_error, p.truth, z, p.drawn));
  }
}

Result<CalibrationFigures> calibration_phase(Hub& hub, EmulatorSide& side, NetCamera& camera,
                                             const std::filesystem::path& base_config,
                                             const std::filesystem::path& overlay,
                                             std::uint64_t test_seed, const Say& say) {
  const RobotModel base = hub.model();
  const std::vector<ToolPose> poses = test_poses(base, 12, test_seed);
  EmulatedOperator op(side);
  CalibrationOptions co;
  co.progress = [&say](const std::string& line) { say("    " + line); };
  TruthLog truth_log(side, overlay.parent_path() / "calibration-truth.csv");
  truth_log.attach(co);
  auto cal = calibrate_and_write(hub, camera, op, base_config, overlay, co, say);
  if (!cal) return cal.error();
  hub.set_model(cal->calibrated);
  say(
      fmt::format("    {} test poses: the virtual tool as the description put it before and as the "
                  "calibrated one puts it, against the true tool",
                  poses.size()));
  auto errors = measure_test_poses(hub, side, poses, base);
  if (!errors) return errors.error();
  CalibrationFigures cf;
  cf.before = error_stats(errors->before);
  cf.after = error_stats(errors->after);
  cf.test_poses = static_cast<int>(poses.size());
  cf.fit_poses = cal->fit.marker_views + cal->fit.touch_offs;
  cf.robot_s = cal->robot_s;
  cf.fit_s = cal->fit.fit_seconds;
  cf.pixel_rms = cal->fit.pixel_rms;
  cf.overlay = overlay.string();
  cf.parameters = compare_parameters(base, cal->fit, truth_log.samples());
  say_comparison(cf.parameters, say);
  say(fmt::format(
      "    virtual -> true tool at {} test poses: before mean {:.2f} p95 {:.2f} max {:.2f} mm; "
      "after mean {:.2f} p95 {:.2f} max {:.2f} mm",
      poses.size(), m_to_mm(cf.before.mean_m), m_to_mm(cf.before.p95_m), m_to_mm(cf.before.max_m),
      m_to_mm(cf.after.mean_m), m_to_mm(cf.after.p95_m), m_to_mm(cf.after.max_m)));
  hub.record_metric(metric::kCalibBeforeMeanMm, m_to_mm(cf.before.mean_m), "mm");
  hub.record_metric(metric::kCalibBeforeMaxMm, m_to_mm(cf.before.max_m), "mm");
  hub.record_metric(metric::kCalibAfterMeanMm, m_to_mm(cf.after.mean_m), "mm");
  hub.record_metric(metric::kCalibAfterMaxMm, m_to_mm(cf.after.max_m), "mm");
  for (const CalibrationParameter& p : cf.parameters) {
    const std::string name = metric::kCalibParamPrefix + p.key;
    hub.record_metric(name, p.identified, "");
    hub.record_metric(name + ".se", p.std_error, "");
    if (!std::isnan(p.truth)) hub.record_metric(name + ".true", p.truth, "");
  }
  return cf;
}

TruthLog::TruthLog(EmulatorSide& side, const std::filesystem::path& csv) : side_(side) {
  csv_ = std::fopen(csv.c_str(), "w");
  if (csv_) {
    std::fputs(
        "kind,q_fw0,q_fw1,q_fw2,q_fw3,dir1,dir2,true0,true1,true2,true3,axis_col,axis_row,flag_"
        "col,flag_row,tool_x,tool_y,tool_z\n",
        csv_);
  }
}

TruthLog::~TruthLog() {
  if (csv_) std::fclose(csv_);
}

void TruthLog::attach(CalibrationOptions& o) {
  o.on_measurement = [this](const calib::MarkerView* v, const calib::TouchOff* t) {
    auto tr = side_.query();
    if (!tr) return;
    const JointVector& q = v ? v->q_fw : t->q_fw;
    const calib::Directions& d = v ? v->dir : t->dir;
    samples_.push_back({q, d, tr->q});
    if (!csv_) return;
    std::fprintf(
        csv_,
        "%s,%.9g,%.9g,%.9g,%.9g,%d,%d,%.9g,%.9g,%.9g,%.9g,%.4f,%.4f,%.4f,%.4f,%.9g,%.9g,%.9g\n",
        v ? "marker" : "touch", q[0], q[1], q[2], q[3], d[1], d[2], tr->q[0], tr->q[1], tr->q[2],
        tr->q[3], v && v->axis_px ? (*v->axis_px)[0] : -1.0,
        v && v->axis_px ? (*v->axis_px)[1] : -1.0, v && v->flag_px ? (*v->flag_px)[0] : -1.0,
        v && v->flag_px ? (*v->flag_px)[1] : -1.0, tr->tool[0], tr->tool[1], tr->tool[2]);
    std::fflush(csv_);
  };
}

Result<CalibrateResult> run_calibration(const RobotModel& model, const CalibrateOptions& o,
                                        CalibrationOperator* person, const Say& say) {
  namespace fs = std::filesystem;
  const fs::path base =
      o.config_path.empty() ? default_robot_config_path() : fs::path(o.config_path);
  CalibrateResult result;
  result.overlay = o.overlay.empty() ? default_overlay_path(base) : o.overlay;
  RigOptions ro;
  ro.config_path = o.config_path;
  ro.serial = o.serial;
  ro.camera = o.camera;
  ro.robot_speed = o.robot_speed;
  ro.bin_dir = o.bin_dir;
  if (o.as_built_seed >= 0) ro.as_built_seed = static_cast<std::uint64_t>(o.as_built_seed);
  auto rig = start_rig(ro, fs::absolute(o.out_dir), say);
  if (!rig) return rig.error();
  struct StopRig {
    Rig& rig;
    ~StopRig() { rig.stop(); }
  } stop_rig{*rig};
  if (!rig->webcam) {
    return Error{AppError::kRigStart,
                 "the robot has no webcam (an emulated robot needs --plant as-built)"};
  }
  if (!rig->side && person == nullptr) {
    return Error{CalibrationError::kNoOperator, "calibration: a real robot needs an operator"};
  }
  HubOptions ho;
  ho.serial_device = rig->device;
  ho.sim_port = rig->sim_port;
  auto hub = Hub::connect(model, ho, nullptr);
  if (!hub) return hub.error();
  if (o.stop != nullptr && o.stop->load()) {
    return Error{HubError::kInterrupted, "calibration: interrupted before it began"};
  }
  const StopWatch watch(o.stop, **hub);
  std::optional<EmulatedOperator> emulated;
  if (rig->side) emulated.emplace(*rig->side);
  CalibrationOperator& op = emulated ? static_cast<CalibrationOperator&>(*emulated) : *person;
  CalibrationOptions co;
  co.marker_poses = o.marker_poses;
  co.touch_offs = o.touch_offs;
  co.seed = o.seed;
  co.progress = [&say](const std::string& line) { say("==> " + line); };
  // with the emulated robot: each measurement beside the truth (a measuring instrument for
  // the record and the comparison said at the end, never given to the fit)
  std::optional<TruthLog> truth;
  if (rig->side) {
    truth.emplace(*rig->side, o.out_dir / "calibration-truth.csv");
    truth->attach(co);
  }
  auto run = calibrate_and_write(**hub, *rig->webcam, op, base, result.overlay, co, say);
  if (!run) return run.error();
  if (truth) {
    result.compared = compare_parameters(model, run->fit, truth->samples());
    say_comparison(result.compared, say);
  }
  result.run = std::move(*run);
  return result;
}

namespace {

using calib::Param;

// The webcam of the emulated robot as built: the as-built mount, and its lens (the emulator's
// radial distortion, normalised by the picture's half-height, is the webcam model's k1 over
// tan^2 of half the field of view).
WebcamModel built_webcam(const RobotModel& description, const AsBuilt& a) {
  const CameraModel cam = plant::as_built_robot(description, a).scene.camera;
  WebcamModel w = nominal_webcam(cam);
  const double t = std::tan(0.5 * deg_to_rad(cam.fovy_deg));
  w.k1 = plant::LensModel{}.k1 / (t * t);
  return w;
}

void set_camera(std::array<double, calib::kParamCount>& t, const WebcamParams& d) {
  for (int i = 0; i < kWebcamParams; ++i) t[calib::kRobotParams + i] = d[i];
}

// Least squares of y = a + b x; nullopt with fewer than 2 distinct x.
std::optional<std::array<double, 2>> line_fit(const std::vector<std::array<double, 2>>& xy) {
  double n = 0, sx = 0, sy = 0, sxx = 0, sxy = 0;
  for (const auto& [x, y] : xy) {
    n += 1;
    sx += x;
    sy += y;
    sxx += x * x;
    sxy += x * y;
  }
  const double det = n * sxx - sx * sx;
  if (n < 2 || !(std::abs(det) > 1e-18)) return std::nullopt;
  const double b = (n * sxy - sx * sy) / det;
  return std::array<double, 2>{(sy - b * sx) / n, b};
}

}  // namespace

std::array<double, calib::kParamCount> drawn_parameters(const RobotModel& description) {
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
  set_camera(t, adjustment(nominal_webcam(description.scene.camera), built_webcam(description, a)));
  return t;
}

std::array<double, calib::kParamCount> true_parameters(const RobotModel& description,
                                                       const std::vector<MeasuredJoints>& samples) {
  std::array<double, calib::kParamCount> t = drawn_parameters(description);
  auto set = [&t](Param p, double v) { t[static_cast<int>(p)] = v; };
  for (Param p : {Param::kZOffset, Param::kZScale, Param::kJ2Zero, Param::kJ3Zero,
                  Param::kWristOffset, Param::kWristGain, Param::kJ2Backlash, Param::kJ3Backlash}) {
    set(p, std::nan(""));
  }
  // Z: true - counts = offset + scale (counts - switch)
  const double sw = description.endstops.closes_at[0];
  std::vector<std::array<double, 2>> z, wrist;
  for (const MeasuredJoints& s : samples) {
    z.push_back({s.q_fw[0] - sw, s.q_true[0] - s.q_fw[0]});
    wrist.push_back({s.q_fw[3], s.q_true[3] - s.q_fw[3]});
  }
  if (auto l = line_fit(z)) {
    set(Param::kZOffset, (*l)[0]);
    set(Param::kZScale, (*l)[1]);
  }
  if (auto l = line_fit(wrist)) {
    set(Param::kWristOffset, (*l)[0]);
    set(Param::kWristGain, (*l)[1]);
  }
  // a belt joint: where it rests after moving up (o_up) and down (o_down); the dead band is
  // their difference, and the zero is the joint map's (calibration.hpp: at the switch the
  // drive is half a band past the joint, then trails it by half a band)
  for (int j = 1; j <= 2; ++j) {
    double up = 0, down = 0;
    int n_up = 0, n_down = 0;
    for (const MeasuredJoints& s : samples) {
      const double off = s.q_true[j] - s.q_fw[j];
      if (s.dir[j] > 0) up += off, ++n_up;
      if (s.dir[j] < 0) down += off, ++n_down;
    }
    if (n_up == 0 || n_down == 0) continue;
    up /= n_up;
    down /= n_down;
    const double band = down - up;
    const double hd = description.endstops.homing_dir[j];
    set(j == 1 ? Param::kJ2Backlash : Param::kJ3Backlash, band);
    set(j == 1 ? Param::kJ2Zero : Param::kJ3Zero, up - 0.5 * hd * band + 0.5 * band);
  }
  return t;
}

std::array<double, calib::kParamCount> identified_parameters(const RobotModel& description,
                                                             const calib::Fit& fit) {
  std::array<double, calib::kParamCount> t = fit.value;
  set_camera(t, adjustment(nominal_webcam(description.scene.camera), fit.camera));
  return t;
}

}  // namespace scaratwin::session
