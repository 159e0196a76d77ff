#include "scaratwin/calibration/calibration.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

#include <fmt/format.h>
#include <Eigen/Dense>
#include <Eigen/SVD>
#include <unsupported/Eigen/NonLinearOptimization>

#include "scaratwin/kinematics/kinematics.hpp"
#include "scaratwin/sim/mjcf.hpp"

namespace scaratwin::calib {
namespace {

constexpr double kMm = 1e-3;
constexpr double kDeg = std::numbers::pi / 180.0;
constexpr double kPercent = 1e-2;

// key, key unit -> SI, fit scale (SI), what makes it observable
const std::array<ParamInfo, kParamCount> kParams{{
    {"a2_mm", kMm, 1.0 * kMm, "marker views spread over the workspace and touch-offs"},
    {"a3_mm", kMm, 1.0 * kMm, "marker views spread over the workspace and touch-offs"},
    {"z_offset_mm", kMm, 1.0 * kMm, "touch-offs on marks of known height"},
    {"z_scale_percent", kPercent, 0.5 * kPercent, "marker views and touch-offs at several heights"},
    {"j2_zero_deg", kDeg, 1.0 * kDeg, "marker views in both elbow configurations"},
    {"j3_zero_deg", kDeg, 1.0 * kDeg, "marker views in both elbow configurations"},
    {"wrist_offset_deg", kDeg, 3.0 * kDeg, "views of the flag marker"},
    {"wrist_gain_percent", kPercent, 3.0 * kPercent,
     "views of the flag marker at several wrist angles"},
    {"jaw_offset_mm", kMm, 0.5 * kMm, "touch-offs at two or more wrist angles"},
    {"j2_backlash_deg", kDeg, 0.3 * kDeg, "J2 reaching poses from both sides"},
    {"j3_backlash_deg", kDeg, 0.3 * kDeg, "J3 reaching poses from both sides"},
    {"camera_dx_mm", kMm, 3.0 * kMm, "the printed pattern on the table"},
    {"camera_dy_mm", kMm, 3.0 * kMm, "the printed pattern on the table"},
    {"camera_dz_mm", kMm, 3.0 * kMm, "the printed pattern and marker views at several heights"},
    {"camera_rx_deg", kDeg, 1.0 * kDeg, "the printed pattern on the table"},
    {"camera_ry_deg", kDeg, 1.0 * kDeg, "the printed pattern on the table"},
    {"camera_rz_deg", kDeg, 1.0 * kDeg, "the printed pattern on the table"},
    {"camera_focal_percent", kPercent, 1.0 * kPercent, "marker views at several heights"},
    {"camera_k1", 1.0, 0.05, "the printed pattern out to the picture's edges"},
}};

using Theta = std::array<double, kParamCount>;

RobotModel model_for(const RobotModel& base, const Theta& t) {
  RobotModel m = base;
  auto v = [&](Param p) { return t[static_cast<int>(p)]; };
  m.dh[1].a_m += v(Param::kA2);
  m.dh[2].a_m += v(Param::kA3);
  m.dh[3].a_m += v(Param::kJawOffset);
  JointCalibration& c = m.calibration;
  c.z_offset_m = v(Param::kZOffset);
  c.z_scale = v(Param::kZScale);
  c.j2_zero_rad = v(Param::kJ2Zero);
  c.j3_zero_rad = v(Param::kJ3Zero);
  c.wrist_offset_rad = v(Param::kWristOffset);
  c.wrist_gain = v(Param::kWristGain);
  c.backlash = {0.0, v(Param::kJ2Backlash), v(Param::kJ3Backlash)};
  for (int i = 0; i < kNumJoints; ++i) c.a_delta_m[i] += m.dh[i].a_m - base.dh[i].a_m;
  return m;
}

WebcamModel camera_for(const WebcamModel& guess, const Theta& t) {
  std::array<double, kWebcamParams> d{};
  for (int i = 0; i < kWebcamParams; ++i) d[i] = t[kRobotParams + i];
  return adjusted(guess, d);
}

struct Problem {
  const RobotModel& base;
  const CameraPrior& prior;
  const Measurements& m;
  const FitOptions& o;
  int rows = 0;

  // residuals, each divided by its expected noise
  void residuals(const Theta& t, Eigen::VectorXd& r) const {
    const RobotModel model = model_for(base, t);
    const WebcamModel cam = camera_for(prior.camera, t);
    int k = 0;
    // the centroid of a marker disc's picture (perspective and lens move it off the centre)
    auto pixel = [&](const std::array<double, 3>& p, double radius, int w, int h,
                     const std::array<double, 2>& seen) {
      double col = 0.0, row = 0.0;
      if (!project_disc(cam, p, radius, w, h, col, row)) col = row = 1e6;
      r[k++] = (col - seen[0]) / o.pixel_sigma;
      r[k++] = (row - seen[1]) / o.pixel_sigma;
    };
    // what the pattern said about the camera
    for (int i = 0; i < kWebcamParams; ++i) r[k++] = t[kRobotParams + i] / prior_sigma(i);
    for (const MarkerView& v : m.markers) {
      const JointVector q = true_joints(model, v.q_fw, v.dir);
      if (v.axis_px) {
        pixel(axis_marker_B(model, q), sim::kMarkerRadiusM, v.width_px, v.height_px, *v.axis_px);
      }
      if (v.flag_px) {
        pixel(flag_marker_B(model, q), sim::kFlagMarkerRadiusM, v.width_px, v.height_px,
              *v.flag_px);
      }
    }
    for (const TouchOff& t_off : m.touches) {
      const JointVector q = true_joints(model, t_off.q_fw, t_off.dir);
      const ToolPose p = forward(model, q);
      r[k++] = (p.x_m - t_off.mark_B[0]) / o.touch_sigma_m;
      r[k++] = (p.y_m - t_off.mark_B[1]) / o.touch_sigma_m;
      r[k++] = (p.z_m - t_off.mark_B[2]) / o.touch_sigma_m;
    }
  }

  double prior_sigma(int i) const {
    const double se = prior.std_error[i];
    return se > 0.0 ? se : kParams[kRobotParams + i].scale_si;
  }

  Theta to_theta(const Eigen::VectorXd& x) const {
    Theta t{};
    for (int i = 0; i < kParamCount; ++i) t[i] = x[i] * kParams[i].scale_si;
    return t;
  }
};

// Eigen's Levenberg-Marquardt functor (unknowns in units of each parameter's scale)
struct Functor {
  using Scalar = double;
  enum { InputsAtCompileTime = Eigen::Dynamic, ValuesAtCompileTime = Eigen::Dynamic };
  using InputType = Eigen::VectorXd;
  using ValueType = Eigen::VectorXd;
  using JacobianType = Eigen::MatrixXd;
  const Problem* p;
  int inputs() const { return kParamCount; }
  int values() const { return p->rows; }
  int operator()(const Eigen::VectorXd& x, Eigen::VectorXd& f) const {
    p->residuals(p->to_theta(x), f);
    return 0;
  }
  int df(const Eigen::VectorXd& x, Eigen::MatrixXd& j) const {
    // central differences: the model is smooth and cheap
    constexpr double h = 1e-5;
    Eigen::VectorXd xp = x, xm = x, fp(p->rows), fm(p->rows);
    for (int i = 0; i < kParamCount; ++i) {
      xp[i] = x[i] + h;
      xm[i] = x[i] - h;
      p->residuals(p->to_theta(xp), fp);
      p->residuals(p->to_theta(xm), fm);
      j.col(i) = (fp - fm) / (2.0 * h);
      xp[i] = xm[i] = x[i];
    }
    return 0;
  }
};

int sign_count(const std::vector<MarkerView>& v, int joint, int s) {
  return static_cast<int>(std::count_if(
      v.begin(), v.end(), [&](const MarkerView& m) { return m.dir[joint] == s && m.axis_px; }));
}

}  // namespace

const ParamInfo& param_info(Param p) { return kParams[static_cast<int>(p)]; }

JointVector true_joints(const RobotModel& calibrated, const JointVector& q_fw,
                        const Directions& dir) {
  JointVector q = firmware_to_joints(calibrated, q_fw);
  const JointVector s = backlash_shift(calibrated, {dir[0], dir[1], dir[2]});
  for (int i = 0; i < kNumJoints; ++i) q[i] += s[i];
  return q;
}

std::array<double, 3> axis_marker_B(const RobotModel& model, const JointVector& q) {
  return sim::marker_position(model, q);
}

std::array<double, 3> flag_marker_B(const RobotModel& model, const JointVector& q) {
  return sim::flag_marker_position(model, q);
}

std::optional<std::string> missing_measurement(const RobotModel& base, const Measurements& m) {
  (void)base;
  int axis = 0, flags = 0, elbow_pos = 0, elbow_neg = 0;
  double z_min = 1e9, z_max = -1e9, w_min = 1e9, w_max = -1e9;
  for (const MarkerView& v : m.markers) {
    if (v.axis_px) {
      ++axis;
      (v.q_fw[2] >= 0.0 ? elbow_pos : elbow_neg)++;
      z_min = std::min(z_min, v.q_fw[0]);
      z_max = std::max(z_max, v.q_fw[0]);
    }
    if (v.flag_px) {
      ++flags;
      w_min = std::min(w_min, v.q_fw[3]);
      w_max = std::max(w_max, v.q_fw[3]);
    }
  }
  if (axis < 12) {
    return fmt::format("marker views: the tool marker was seen at {} poses, at least 12 are needed",
                       axis);
  }
  if (elbow_pos < 3 || elbow_neg < 3) {
    return fmt::format(
        "marker views in both elbow configurations: {} with the elbow bent one way and {} the "
        "other, at least 3 of each are needed",
        elbow_pos, elbow_neg);
  }
  if (z_max - z_min < 0.04) {
    return fmt::format(
        "marker views at several heights: Z spans {:.1f} mm, at least 40 mm are needed",
        (z_max - z_min) * 1e3);
  }
  if (flags < 6 || w_max - w_min < 60.0 * kDeg) {
    return fmt::format(
        "flag marker views at several wrist angles: {} views over {:.0f} deg, at least 6 over "
        "60 deg are needed",
        flags, flags > 0 ? (w_max - w_min) / kDeg : 0.0);
  }
  for (int j = 1; j <= 2; ++j) {
    const int up = sign_count(m.markers, j, +1), down = sign_count(m.markers, j, -1);
    if (up < 3 || down < 3) {
      return fmt::format(
          "J{} reaching poses from both sides (its backlash): {} views after moving up and {} "
          "after moving down, at least 3 of each are needed",
          j + 1, up, down);
    }
  }
  if (m.touches.size() < 3) {
    return fmt::format("touch-offs: {} marks touched, at least 3 are needed", m.touches.size());
  }
  double t_min = 1e9, t_max = -1e9;
  for (const TouchOff& t : m.touches) {
    t_min = std::min(t_min, t.q_fw[3]);
    t_max = std::max(t_max, t.q_fw[3]);
  }
  if (t_max - t_min < 45.0 * kDeg) {
    return fmt::format(
        "touch-offs at two or more wrist angles (the jaw offset): they span {:.0f} deg, at least "
        "45 deg are needed",
        (t_max - t_min) / kDeg);
  }
  return std::nullopt;
}

namespace {

// One Levenberg-Marquardt solve: the unknowns (in scale units), the residuals at them, the
// rows' count and the solver's iterations.
struct Solve {
  Eigen::VectorXd x, r;
  int rows = 0, iterations = 0;
  bool improper = false;
};

Solve solve(const Problem& prob0) {
  Problem prob = prob0;
  prob.rows = kWebcamParams;
  for (const MarkerView& v : prob.m.markers) {
    prob.rows += 2 * ((v.axis_px ? 1 : 0) + (v.flag_px ? 1 : 0));
  }
  prob.rows += 3 * static_cast<int>(prob.m.touches.size());
  Functor f{&prob};
  Solve s;
  s.rows = prob.rows;
  s.x = Eigen::VectorXd::Zero(kParamCount);
  Eigen::LevenbergMarquardt<Functor> lm(f);
  lm.parameters.maxfev = prob.o.max_iterations;
  lm.parameters.xtol = 1e-12;
  lm.parameters.ftol = 1e-12;
  const auto status = lm.minimize(s.x);
  s.iterations = static_cast<int>(lm.iter);
  s.improper = status == Eigen::LevenbergMarquardtSpace::ImproperInputParameters;
  s.r.resize(prob.rows);
  prob.residuals(prob.to_theta(s.x), s.r);
  return s;
}

// Each marker point's residual in pixels, in the order of the residual rows, with the view
// and which marker (0 the axis marker, 1 the flag) it belongs to.
struct PointResidual {
  std::size_t view;
  int marker;
  double px;
};

std::vector<PointResidual> marker_residuals(const Measurements& m, const Eigen::VectorXd& r,
                                            double pixel_sigma) {
  std::vector<PointResidual> out;
  int k = kWebcamParams;
  for (std::size_t i = 0; i < m.markers.size(); ++i) {
    const MarkerView& v = m.markers[i];
    for (int which = 0; which < 2; ++which) {
      if (!(which == 0 ? v.axis_px : v.flag_px)) continue;
      out.push_back({i, which, std::hypot(r[k], r[k + 1]) * pixel_sigma});
      k += 2;
    }
  }
  return out;
}

}  // namespace

Result<Fit> fit(const RobotModel& base, const CameraPrior& camera, const Measurements& given,
                const FitOptions& o) {
  if (auto missing = missing_measurement(base, given)) {
    return Error{CalibrationError::kNotEnoughData,
                 "calibration needs more measurements: " + *missing};
  }
  // A marker partly hidden or mistaken (a reflection, a cut-off disc) puts its centroid
  // pixels away from where one robot can explain it: such points are set aside, the worst
  // first, and the fit repeated, as long as they stay a small share of all points.
  Measurements m = given;
  int given_points = 0;
  for (const MarkerView& v : m.markers) given_points += (v.axis_px ? 1 : 0) + (v.flag_px ? 1 : 0);
  Problem prob{base, camera, m, o};
  Solve s = solve(prob);
  int outliers = 0;
  for (int round = 0; round < 8 && !s.improper; ++round) {
    const auto res = marker_residuals(m, s.r, o.pixel_sigma);
    double worst = 0.0;
    for (const PointResidual& p : res) worst = std::max(worst, p.px);
    if (worst <= o.outlier_px) break;
    const double cut = std::max(o.outlier_px, 0.5 * worst);
    for (const PointResidual& p : res) {
      if (p.px <= cut) continue;
      (p.marker == 0 ? m.markers[p.view].axis_px : m.markers[p.view].flag_px).reset();
      ++outliers;
    }
    if (outliers > o.max_outlier_fraction * given_points) {
      return Error{CalibrationError::kInconsistent,
                   fmt::format("calibration: {} of {} marker points do not fit one robot "
                               "(each more than {:.1f} px off): a belt may have slipped or "
                               "steps been lost during the routine, or the markers be hard "
                               "to see; check the belts and the light and calibrate again "
                               "(no overlay written)",
                               outliers, given_points, o.outlier_px)};
    }
    if (auto missing = missing_measurement(base, m)) {
      return Error{CalibrationError::kNotEnoughData,
                   fmt::format("calibration: with {} marker points set aside as outliers "
                               "the measurements lack {}",
                               outliers, *missing)};
    }
    s = solve(prob);
  }
  if (s.improper) {
    return Error{CalibrationError::kSolver,
                 "calibration: the solver refused its input (no measurements?)"};
  }

  Fit out;
  out.pattern_points = camera.corners;
  out.outliers = outliers;
  out.iterations = s.iterations;
  for (const MarkerView& v : m.markers) {
    const int n = (v.axis_px ? 1 : 0) + (v.flag_px ? 1 : 0);
    out.marker_points += n;
    if (n > 0) ++out.marker_views;
  }
  out.touch_offs = static_cast<int>(m.touches.size());
  prob.rows = s.rows;
  Functor f{&prob};
  const Eigen::VectorXd& x = s.x;
  const Eigen::VectorXd& r = s.r;

  // observability: the Jacobian at the solution must have full column rank
  Eigen::MatrixXd jac(prob.rows, kParamCount);
  f.df(x, jac);
  Eigen::JacobiSVD<Eigen::MatrixXd> svd(jac, Eigen::ComputeThinV);
  const auto& sv = svd.singularValues();
  if (!(sv[kParamCount - 1] > 1e-6 * sv[0])) {
    const Eigen::VectorXd null = svd.matrixV().col(kParamCount - 1);
    Eigen::Index worst = 0;
    null.cwiseAbs().maxCoeff(&worst);
    return Error{CalibrationError::kNotDetermined,
                 fmt::format("calibration: {} is not determined by these measurements; it "
                             "needs {}",
                             kParams[worst].key, kParams[worst].needs)};
  }

  // the residuals in their units
  double pix2 = 0.0, touch2 = 0.0;
  int pix_n = 0;
  for (const PointResidual& p : marker_residuals(m, r, o.pixel_sigma)) {
    pix2 += p.px * p.px;
    ++pix_n;
    out.worst_marker_px = std::max(out.worst_marker_px, p.px);
  }
  int k = kWebcamParams + 2 * pix_n;
  for (int i = 0; i < out.touch_offs; ++i, k += 3) {
    touch2 += std::pow(r[k] * o.touch_sigma_m, 2) + std::pow(r[k + 1] * o.touch_sigma_m, 2) +
              std::pow(r[k + 2] * o.touch_sigma_m, 2);
  }
  out.pixel_rms = pix_n > 0 ? std::sqrt(pix2 / pix_n) : 0.0;
  out.marker_rms_px = out.pixel_rms;
  out.touch_rms_m = out.touch_offs > 0 ? std::sqrt(touch2 / out.touch_offs) : 0.0;
  if (out.pixel_rms > o.max_pixel_rms || out.touch_rms_m > o.max_touch_rms_m) {
    return Error{
        CalibrationError::kInconsistent,
        fmt::format("calibration: the measurements do not fit one robot (residual {:.2f} px, "
                    "limit {:.2f} px; touch-offs {:.2f} mm, limit {:.2f} mm): a belt may "
                    "have slipped or steps been lost during the routine, or a marker been "
                    "mistaken; check the belts and calibrate again (no overlay written)",
                    out.pixel_rms, o.max_pixel_rms, out.touch_rms_m * 1e3,
                    o.max_touch_rms_m * 1e3)};
  }

  // standard errors: (J^T J)^-1 scaled by the residual variance per degree of freedom
  const int dof = std::max(1, prob.rows - kParamCount);
  const double s2 = r.squaredNorm() / dof;
  const Eigen::MatrixXd cov = (jac.transpose() * jac).inverse() * std::max(s2, 1e-12);
  const Theta t = prob.to_theta(x);
  for (int i = 0; i < kParamCount; ++i) {
    out.value[i] = t[i];
    out.std_error[i] = std::sqrt(std::max(cov(i, i), 0.0)) * kParams[i].scale_si;
    if (out.std_error[i] > o.max_normalised_error * kParams[i].scale_si) {
      return Error{
          CalibrationError::kNotDetermined,
          fmt::format("calibration: {} is poorly determined (std error {:.3g} {}); "
                      "it needs more {}",
                      kParams[i].key, out.std_error[i] / kParams[i].to_si,
                      kParams[i].key.substr(kParams[i].key.rfind('_') + 1), kParams[i].needs)};
    }
  }
  out.camera = camera_for(camera.camera, t);
  return out;
}

RobotModel apply(const RobotModel& base, const Fit& fit) {
  RobotModel m = model_for(base, fit.value);
  m.webcam = to_description(fit.camera);
  return m;
}

std::string overlay_text(const RobotModel& base, const Fit& f, const std::string& base_ref,
                         const std::string& date_utc) {
  std::string t;
  t += "# scaratwin calibration overlay: the robot as `scaratwin calibrate` measured it.\n";
  t += "# Load it with --config <this file>; it refines the base description named below.\n";
  t += "# identified: [value, standard error] in the key's unit, as deviations from the base.\n";
  t += fmt::format("base = \"{}\"\n\n[calibration]\n", base_ref);
  t += fmt::format("date = \"{}\"\nrobot = \"{}\"\n", date_utc, base.name);
  t += fmt::format("pattern_points = {}\nmarker_views = {}\nmarker_points = {}\n", f.pattern_points,
                   f.marker_views, f.marker_points);
  t += fmt::format("outliers = {}\ntouch_offs = {}\n", f.outliers, f.touch_offs);
  t += fmt::format("pixel_rms = {:.4f}\ntouch_rms_mm = {:.4f}\nfit_s = {:.3f}\n\n", f.pixel_rms,
                   f.touch_rms_m * 1e3, f.fit_seconds);
  t += "[calibration.identified]\n";
  for (int i = 0; i < kParamCount; ++i) {
    t += fmt::format("{} = [{:.12g}, {:.3g}]\n", kParams[i].key, f.value[i] / kParams[i].to_si,
                     f.std_error[i] / kParams[i].to_si);
  }
  const WebcamModel& c = f.camera;
  t += "\n[calibration.webcam]\n";
  t += fmt::format("pos_m = [{:.9g}, {:.9g}, {:.9g}]\n", c.pos_m[0], c.pos_m[1], c.pos_m[2]);
  t += "r_bc = [";
  for (int i = 0; i < 9; ++i) t += fmt::format("{}{:.12g}", i ? ", " : "", c.r_bc[i]);
  t += "]\n";
  t += fmt::format("f_px = {:.9g}\ncx_px = {:.9g}\ncy_px = {:.9g}\nk1 = {:.9g}\nk2 = {:.9g}\n",
                   c.f_px, c.cx_px, c.cy_px, c.k1, c.k2);
  t += fmt::format("width_px = {}\nheight_px = {}\n", c.width_px, c.height_px);
  return t;
}

WebcamCalibration to_description(const WebcamModel& c) {
  WebcamCalibration w;
  w.valid = true;
  w.pos_m = c.pos_m;
  w.r_bc = c.r_bc;
  w.f_px = c.f_px;
  w.cx_px = c.cx_px;
  w.cy_px = c.cy_px;
  w.k1 = c.k1;
  w.k2 = c.k2;
  w.width_px = c.width_px;
  w.height_px = c.height_px;
  return w;
}

WebcamModel from_description(const WebcamCalibration& w) {
  WebcamModel c;
  c.pos_m = w.pos_m;
  c.r_bc = w.r_bc;
  c.f_px = w.f_px;
  c.cx_px = w.cx_px;
  c.cy_px = w.cy_px;
  c.k1 = w.k1;
  c.k2 = w.k2;
  c.width_px = w.width_px;
  c.height_px = w.height_px;
  return c;
}

}  // namespace scaratwin::calib
