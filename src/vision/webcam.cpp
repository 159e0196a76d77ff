#include "scaratwin/vision/webcam.hpp"

#include <cmath>

#include <Eigen/Geometry>

#include "scaratwin/vision/vision.hpp"

namespace scaratwin {
namespace {

Eigen::Matrix3d rot(const WebcamModel& c) {
  return Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(c.r_bc.data());
}

}  // namespace

WebcamModel nominal_webcam(const CameraModel& camera) {
  WebcamModel w;
  const CameraAxes a = camera_axes(camera);
  for (int i = 0; i < 3; ++i) {
    w.r_bc[3 * i + 0] = a.x[i];
    w.r_bc[3 * i + 1] = a.y[i];
    w.r_bc[3 * i + 2] = a.z[i];
  }
  w.pos_m = camera.pos_m;
  w.width_px = camera.width_px;
  w.height_px = camera.height_px;
  constexpr double kPi = 3.14159265358979323846;
  w.f_px = 0.5 * camera.height_px / std::tan(0.5 * camera.fovy_deg * kPi / 180.0);
  w.cx_px = 0.5 * camera.width_px;
  w.cy_px = 0.5 * camera.height_px;
  return w;
}

bool project(const WebcamModel& c, const std::array<double, 3>& p_B, int width_px,
             int height_px, double& col, double& row) {
  const Eigen::Vector3d d(p_B[0] - c.pos_m[0], p_B[1] - c.pos_m[1], p_B[2] - c.pos_m[2]);
  const Eigen::Vector3d pc = rot(c).transpose() * d;
  const double depth = -pc.z();
  if (!(depth > 1e-9) || c.height_px <= 0) return false;
  const double xn = pc.x() / depth, yn = pc.y() / depth;
  const double r2 = xn * xn + yn * yn;
  const double s = 1.0 + c.k1 * r2 + c.k2 * r2 * r2;
  const double scale = static_cast<double>(height_px) / c.height_px;
  col = 0.5 * width_px + (c.cx_px - 0.5 * c.width_px) * scale + c.f_px * scale * xn * s;
  row = 0.5 * height_px + (c.cy_px - 0.5 * c.height_px) * scale - c.f_px * scale * yn * s;
  return true;
}

bool unproject_to_plane(const WebcamModel& c, double col, double row, int width_px,
                        int height_px, double plane_z_m, std::array<double, 3>& p_B) {
  if (c.height_px <= 0 || !(c.f_px > 0.0)) return false;
  const double scale = static_cast<double>(height_px) / c.height_px;
  const double f = c.f_px * scale;
  const double xd = (col - 0.5 * width_px - (c.cx_px - 0.5 * c.width_px) * scale) / f;
  const double yd = -(row - 0.5 * height_px - (c.cy_px - 0.5 * c.height_px) * scale) / f;
  // undo the distortion: x_n s(r_n) = x_d by fixed-point iteration
  double xn = xd, yn = yd;
  for (int i = 0; i < 30; ++i) {
    const double r2 = xn * xn + yn * yn;
    const double s = 1.0 + c.k1 * r2 + c.k2 * r2 * r2;
    xn = xd / s;
    yn = yd / s;
  }
  const Eigen::Vector3d dir = rot(c) * Eigen::Vector3d(xn, yn, -1.0);
  if (std::abs(dir.z()) < 1e-12) return false;
  const double t = (plane_z_m - c.pos_m[2]) / dir.z();
  if (!(t > 0.0)) return false;
  p_B = {c.pos_m[0] + t * dir.x(), c.pos_m[1] + t * dir.y(), plane_z_m};
  return true;
}

WebcamModel adjusted(const WebcamModel& base, const std::array<double, kWebcamParams>& d) {
  WebcamModel w = base;
  for (int i = 0; i < 3; ++i) w.pos_m[i] += d[i];
  const Eigen::Vector3d rv(d[3], d[4], d[5]);
  const double angle = rv.norm();
  Eigen::Matrix3d r = rot(base);
  if (angle > 0.0) r = r * Eigen::AngleAxisd(angle, rv / angle).toRotationMatrix();
  Eigen::Map<Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(w.r_bc.data()) = r;
  w.f_px = base.f_px * (1.0 + d[6]);
  w.k1 = base.k1 + d[7];
  return w;
}

}  // namespace scaratwin
