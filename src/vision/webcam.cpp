// The webcam model (projection through a radial lens) and its fit to the pattern's corners.
#include <Eigen/Dense>
#include <unsupported/Eigen/NonLinearOptimization>
#include <unsupported/Eigen/NumericalDiff>

#include <algorithm>
#include <cmath>
#include <map>

#include <fmt/format.h>

#include "scaratwin/core/units.hpp"
#include "scaratwin/vision/webcam.hpp"

namespace scaratwin {
namespace {

using Vec3 = std::array<double, 3>;

Eigen::Matrix3d rotation(const WebcamModel& c) {
  Eigen::Matrix3d r;
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) r(i, j) = c.r_bc[3 * i + j];
  }
  return r;
}

// Pixel of distorted normalised coordinates (xd, yd) in a width x height picture, and back.
void to_pixel(const WebcamModel& c, double xd, double yd, int width, int height, double& col,
              double& row) {
  const double s = static_cast<double>(height) / c.height_px;
  col = 0.5 * width + s * (c.cx_px - 0.5 * c.width_px + c.f_px * xd);
  row = 0.5 * height + s * (c.cy_px - 0.5 * c.height_px - c.f_px * yd);
}
void from_pixel(const WebcamModel& c, double col, double row, int width, int height, double& xd,
                double& yd) {
  const double s = static_cast<double>(height) / c.height_px;
  xd = ((col - 0.5 * width) / s + 0.5 * c.width_px - c.cx_px) / c.f_px;
  yd = -((row - 0.5 * height) / s + 0.5 * c.height_px - c.cy_px) / c.f_px;
}

double undistort_scale(const WebcamModel& c, double rho2) {
  return 1.0 + c.k1 * rho2 + c.k2 * rho2 * rho2;
}

}  // namespace

WebcamModel nominal_webcam(const CameraModel& camera) {
  const CameraAxes a = camera_axes(camera);
  WebcamModel w;
  w.pos_m = camera.pos_m;
  for (int i = 0; i < 3; ++i) {
    w.r_bc[3 * i + 0] = a.x[i];
    w.r_bc[3 * i + 1] = a.y[i];
    w.r_bc[3 * i + 2] = a.z[i];
  }
  w.width_px = camera.width_px;
  w.height_px = camera.height_px;
  w.f_px = 0.5 * camera.height_px / std::tan(0.5 * deg_to_rad(camera.fovy_deg));
  w.cx_px = 0.5 * camera.width_px;
  w.cy_px = 0.5 * camera.height_px;
  return w;
}

bool project(const WebcamModel& c, const Vec3& p, int width_px, int height_px, double& col,
             double& row) {
  const Eigen::Vector3d d(p[0] - c.pos_m[0], p[1] - c.pos_m[1], p[2] - c.pos_m[2]);
  const Eigen::Vector3d pc = rotation(c).transpose() * d;
  if (!(-pc.z() > 1e-9)) return false;
  const double ux = pc.x() / -pc.z(), uy = pc.y() / -pc.z();
  const double r = std::hypot(ux, uy);
  // the distorted radius rho with rho * (1 + k1 rho^2 + k2 rho^4) = r (Newton from rho = r)
  double rho = r;
  for (int i = 0; i < 30; ++i) {
    const double rho2 = rho * rho;
    const double g = rho * undistort_scale(c, rho2) - r;
    const double dg = 1.0 + 3.0 * c.k1 * rho2 + 5.0 * c.k2 * rho2 * rho2;
    if (!(dg > 1e-6)) return false;  // beyond the lens model's fold
    const double step = g / dg;
    rho -= step;
    if (std::abs(step) < 1e-14) break;
  }
  if (!(rho >= 0.0) || std::abs(rho * undistort_scale(c, rho * rho) - r) > 1e-9) return false;
  const double k = r > 0.0 ? rho / r : 1.0;
  to_pixel(c, ux * k, uy * k, width_px, height_px, col, row);
  return true;
}

bool project_disc(const WebcamModel& c, const Vec3& centre, double radius, int width_px,
                  int height_px, double& col, double& row) {
  // the outline as a polygon; its area centroid
  constexpr int kPoints = 72;
  std::array<std::array<double, 2>, kPoints> poly{};
  for (int i = 0; i < kPoints; ++i) {
    const double a = 2.0 * kPi * i / kPoints;
    const Vec3 p{centre[0] + radius * std::cos(a), centre[1] + radius * std::sin(a), centre[2]};
    if (!project(c, p, width_px, height_px, poly[i][0], poly[i][1])) return false;
  }
  double area = 0.0, sx = 0.0, sy = 0.0;
  for (int i = 0; i < kPoints; ++i) {
    const auto& a = poly[static_cast<std::size_t>(i)];
    const auto& b = poly[static_cast<std::size_t>((i + 1) % kPoints)];
    const double cr = a[0] * b[1] - b[0] * a[1];
    area += cr;
    sx += (a[0] + b[0]) * cr;
    sy += (a[1] + b[1]) * cr;
  }
  if (std::abs(area) < 1e-12) return project(c, centre, width_px, height_px, col, row);
  col = sx / (3.0 * area);
  row = sy / (3.0 * area);
  return true;
}

bool unproject_to_plane(const WebcamModel& c, double col, double row, int width_px, int height_px,
                        double plane_z_m, Vec3& p) {
  double xd = 0, yd = 0;
  from_pixel(c, col, row, width_px, height_px, xd, yd);
  const double k = undistort_scale(c, xd * xd + yd * yd);
  const Eigen::Vector3d dir = rotation(c) * Eigen::Vector3d(xd * k, yd * k, -1.0);
  if (std::abs(dir.z()) < 1e-12) return false;
  const double t = (plane_z_m - c.pos_m[2]) / dir.z();
  if (!(t > 0.0)) return false;
  p = {c.pos_m[0] + t * dir.x(), c.pos_m[1] + t * dir.y(), plane_z_m};
  return true;
}

WebcamModel adjusted(const WebcamModel& base, const WebcamParams& d) {
  WebcamModel c = base;
  for (int i = 0; i < 3; ++i) c.pos_m[i] += d[i];
  const Eigen::Vector3d w(d[3], d[4], d[5]);
  const double angle = w.norm();
  Eigen::Matrix3d r = rotation(base);
  if (angle > 0.0) r = r * Eigen::AngleAxisd(angle, w / angle).toRotationMatrix();
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) c.r_bc[3 * i + j] = r(i, j);
  }
  c.f_px = base.f_px * (1.0 + d[6]);
  c.k1 = base.k1 + d[7];
  return c;
}

WebcamParams adjustment(const WebcamModel& base, const WebcamModel& c) {
  WebcamParams d{};
  for (int i = 0; i < 3; ++i) d[i] = c.pos_m[i] - base.pos_m[i];
  const Eigen::AngleAxisd aa(rotation(base).transpose() * rotation(c));
  const Eigen::Vector3d w = aa.angle() * aa.axis();
  for (int i = 0; i < 3; ++i) d[3 + i] = w[i];
  d[6] = (c.f_px / c.height_px) / (base.f_px / base.height_px) - 1.0;
  d[7] = c.k1 - base.k1;
  return d;
}

namespace {

// One tag seen: its corners in B and where the detector put them.
struct Match {
  std::array<Vec3, 4> p_B;
  std::array<std::array<double, 2>, 4> px;
};

// Where the detector reports a tag's corners in a picture taken by `c`: it fits a straight line
// to each edge of the black square and intersects neighbouring lines. The lens bends the edges,
// so these are not the corners' own projections (a 0.2 px pull towards the picture's centre
// here): the fit compares like with like. False when a point cannot be projected.
bool seen_corners(const WebcamModel& c, const std::array<Vec3, 4>& p, int width, int height,
                  std::array<std::array<double, 2>, 4>& out) {
  constexpr int kSamples = 16;  // points per edge, spread between its corners
  std::array<Eigen::Vector2d, 4> mid, dir;
  for (int e = 0; e < 4; ++e) {
    const Vec3& a = p[static_cast<std::size_t>(e)];
    const Vec3& b = p[static_cast<std::size_t>((e + 1) % 4)];
    Eigen::Matrix<double, 2, kSamples> pts;
    for (int s = 0; s < kSamples; ++s) {
      const double t = (1.0 + s) / (kSamples + 1);
      const Vec3 q{a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1]), a[2] + t * (b[2] - a[2])};
      double col = 0, row = 0;
      if (!project(c, q, width, height, col, row)) return false;
      pts.col(s) << col, row;
    }
    // total least squares: the line through the centroid along the principal direction
    mid[static_cast<std::size_t>(e)] = pts.rowwise().mean();
    const Eigen::Matrix<double, 2, kSamples> centred =
        pts.colwise() - mid[static_cast<std::size_t>(e)];
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> eig(centred * centred.transpose());
    dir[static_cast<std::size_t>(e)] = eig.eigenvectors().col(1);
  }
  for (int k = 0; k < 4; ++k) {
    // corner k joins edge k-1 (from corner k-1) and edge k (to corner k+1)
    const auto i = static_cast<std::size_t>((k + 3) % 4), j = static_cast<std::size_t>(k);
    Eigen::Matrix2d m;
    m << dir[i], -dir[j];
    const Eigen::Vector2d ab = m.colPivHouseholderQr().solve(mid[j] - mid[i]);
    const Eigen::Vector2d x = mid[i] + ab[0] * dir[i];
    out[static_cast<std::size_t>(k)] = {x[0], x[1]};
  }
  return true;
}

// The corners' reprojection residuals for the parameters in use (`free` maps the optimiser's
// vector onto the 8 parameters; the others stay 0).
struct Residuals {
  using Scalar = double;
  using InputType = Eigen::VectorXd;
  using ValueType = Eigen::VectorXd;
  using JacobianType = Eigen::MatrixXd;
  enum { InputsAtCompileTime = Eigen::Dynamic, ValuesAtCompileTime = Eigen::Dynamic };

  const WebcamModel* guess;
  const std::vector<Match>* matches;
  std::vector<int> free;
  int width, height;

  int inputs() const { return static_cast<int>(free.size()); }
  int values() const { return static_cast<int>(8 * matches->size()); }

  WebcamParams params(const Eigen::VectorXd& x) const {
    WebcamParams d{};
    for (std::size_t i = 0; i < free.size(); ++i) d[free[i]] = x[static_cast<Eigen::Index>(i)];
    return d;
  }
  int operator()(const Eigen::VectorXd& x, Eigen::VectorXd& fvec) const {
    const WebcamModel c = adjusted(*guess, params(x));
    for (std::size_t i = 0; i < matches->size(); ++i) {
      const Match& m = (*matches)[i];
      std::array<std::array<double, 2>, 4> px{};
      const bool seen = seen_corners(c, m.p_B, width, height, px);
      for (std::size_t k = 0; k < 4; ++k) {
        const auto at = static_cast<Eigen::Index>(8 * i + 2 * k);
        // a tag that cannot be seen from here: far off
        fvec[at] = seen ? px[k][0] - m.px[k][0] : 1e4;
        fvec[at + 1] = seen ? px[k][1] - m.px[k][1] : 1e4;
      }
    }
    return 0;
  }
};

struct Solved {
  Eigen::VectorXd x;
  Eigen::VectorXd residuals;
  Eigen::MatrixXd jacobian;
  int status = 0;
};

Solved solve(const Residuals& f, const Eigen::VectorXd& start) {
  Eigen::NumericalDiff<Residuals, Eigen::Central> diff(f, 1e-7);
  Eigen::LevenbergMarquardt<Eigen::NumericalDiff<Residuals, Eigen::Central>> lm(diff);
  lm.parameters.maxfev = 4000;
  lm.parameters.xtol = 1e-12;
  lm.parameters.ftol = 1e-12;
  Solved s;
  s.x = start;
  s.status = static_cast<int>(lm.minimize(s.x));
  s.residuals.resize(f.values());
  f(s.x, s.residuals);
  s.jacobian.resize(f.values(), f.inputs());
  diff.df(s.x, s.jacobian);
  return s;
}

}  // namespace

Result<WebcamFit> calibrate_webcam(const WebcamModel& guess, const std::vector<TagCorners>& tags,
                                   int width_px, int height_px, const RobotModel& model,
                                   const WebcamFitOptions& o) {
  if (width_px < 16 || height_px < 16) {
    return Error{
        VisionError::kPictureTooSmall,
        fmt::format("calibrate_webcam: a {}x{} picture is too small", width_px, height_px)};
  }
  std::map<int, const PatternTag*> by_id;
  const std::vector<PatternTag> pattern = pattern_corners(model);
  for (const PatternTag& t : pattern) by_id[t.id] = &t;
  std::vector<Match> matches;
  std::vector<int> used;
  for (const TagCorners& t : tags) {
    const auto it = by_id.find(t.id);
    if (it == by_id.end() || std::find(used.begin(), used.end(), t.id) != used.end()) continue;
    used.push_back(t.id);
    matches.push_back({it->second->p_B, t.px});
  }
  const int n_tags = static_cast<int>(used.size());
  if (n_tags < std::max(o.min_tags, 2)) {
    return Error{VisionError::kTooFewTags,
                 fmt::format("calibrate_webcam: {} of the pattern's {} tags seen ({} tags "
                             "detected in all), at least {} needed: is the pattern on the "
                             "table, in view and not hidden by the arm?",
                             n_tags, pattern.size(), tags.size(), std::max(o.min_tags, 2))};
  }
  Residuals f{&guess, &matches, {0, 1, 2, 3, 4, 5, 7}, width_px, height_px};
  // first with the focal length held at the guess's
  Solved fixed = solve(f, Eigen::VectorXd::Zero(7));
  // is the focal length determined by these corners? Its variance inflation at the solution:
  // (J^T J)^-1_ff (J^T J)_ff is 1 for a parameter uncorrelated with the others.
  Residuals all = f;
  all.free = {0, 1, 2, 3, 4, 5, 6, 7};
  Eigen::VectorXd x8(8);
  x8 << fixed.x.head<6>(), 0.0, fixed.x[6];
  Eigen::MatrixXd j8(all.values(), 8);
  Eigen::NumericalDiff<Residuals, Eigen::Central> diff8(all, 1e-7);
  diff8.df(x8, j8);
  const Eigen::MatrixXd n8 = j8.transpose() * j8;
  const Eigen::FullPivLU<Eigen::MatrixXd> lu8(n8);
  const double inflation =
      lu8.isInvertible() ? lu8.inverse()(6, 6) * n8(6, 6) : std::numeric_limits<double>::infinity();
  WebcamFit fit;
  fit.focal_inflation = inflation;
  Solved best = fixed;
  Residuals used_f = f;
  if (inflation < o.max_focal_inflation) {
    best = solve(all, x8);
    used_f = all;
    fit.focal_fitted = true;
    fit.note = fmt::format("focal length fitted (variance inflation {:.1f})", inflation);
  } else {
    fit.note = fmt::format(
        "focal length held at the guess's {:.2f} px: the corners cannot tell it from the "
        "camera's distance (variance inflation {:.3g} >= {:.3g}; a flat pattern seen "
        "square-on)",
        guess.f_px, inflation, o.max_focal_inflation);
  }
  fit.params = used_f.params(best.x);
  fit.camera = adjusted(guess, fit.params);
  fit.tags = n_tags;
  fit.corners = static_cast<int>(4 * matches.size());
  const Eigen::Index m = best.residuals.size();
  double ss = 0.0, worst = 0.0;
  for (Eigen::Index i = 0; i < m; i += 2) {
    const double e2 =
        best.residuals[i] * best.residuals[i] + best.residuals[i + 1] * best.residuals[i + 1];
    ss += e2;
    worst = std::max(worst, std::sqrt(e2));
  }
  fit.rms_px = std::sqrt(ss / static_cast<double>(m / 2));
  fit.max_px = worst;
  if (!std::isfinite(fit.rms_px) || worst >= 1e3) {
    return Error{VisionError::kNoConvergence,
                 fmt::format("calibrate_webcam: the fit did not converge (status {}, rms "
                             "{:.3g} px): is the guess close to the camera's pose?",
                             best.status, fit.rms_px)};
  }
  if (fit.rms_px > o.max_rms_px) {
    return Error{VisionError::kResidualTooLarge,
                 fmt::format("calibrate_webcam: residual {:.2f} px rms ({:.2f} px max) over "
                             "{} corners is above {:.2f} px: does the printed pattern match "
                             "the description (tag size, spacing), is it lying flat, is the "
                             "picture sharp?",
                             fit.rms_px, worst, fit.corners, o.max_rms_px)};
  }
  // standard errors from the residual's variance and the normal matrix
  const auto p = static_cast<Eigen::Index>(used_f.free.size());
  const double sigma2 = ss / static_cast<double>(std::max<Eigen::Index>(m - p, 1));
  const Eigen::MatrixXd normal = best.jacobian.transpose() * best.jacobian;
  const Eigen::MatrixXd cov = sigma2 * normal.ldlt().solve(Eigen::MatrixXd::Identity(p, p));
  for (Eigen::Index i = 0; i < p; ++i) {
    fit.std_error[used_f.free[static_cast<std::size_t>(i)]] = std::sqrt(std::max(cov(i, i), 0.0));
  }
  return fit;
}

}  // namespace scaratwin
