// The physical overhead webcam: a pinhole with radial distortion (k1, k2 on normalised
// coordinates), placed anywhere in the base frame B. The virtual scene camera stays the
// description's distortion-free pinhole (vision.hpp); a real webcam (or the emulated robot's,
// which renders its own world through a barrel lens) needs this model and a calibration.
// Pure.
//
// Conventions as vision.hpp: camera axes as MuJoCo's (x right, y up, looking along -z);
// pixel (col, row) covers [col, col + 1) x [row, row + 1), row 0 at the top. The intrinsics
// are given for width_px x height_px and scale with the picture's height.
#pragma once

#include <array>

#include "scaratwin/kinematics/robot_model.hpp"

namespace scaratwin {

struct WebcamModel {
  std::array<double, 3> pos_m{};          // optical centre in B
  std::array<double, 9> r_bc{};           // rotation B <- camera, row-major
  double f_px = 0.0, cx_px = 0.0, cy_px = 0.0;
  double k1 = 0.0, k2 = 0.0;
  int width_px = 640, height_px = 480;
};

// The description's camera as a webcam: its pose, its field of view, no distortion.
WebcamModel nominal_webcam(const CameraModel& camera);

// Pixel of a point in B in a picture of width_px x height_px; false when behind the camera.
bool project(const WebcamModel& camera, const std::array<double, 3>& p_B, int width_px,
             int height_px, double& col, double& row);

// Point of the plane z = plane_z_m seen at a pixel (distortion undone by iteration); false
// when the ray misses the plane.
bool unproject_to_plane(const WebcamModel& camera, double col, double row, int width_px,
                        int height_px, double plane_z_m, std::array<double, 3>& p_B);

// Small adjustments of a webcam, the unknowns of its calibration: position (m, 3), rotation
// vector in the camera's own frame (rad, 3), relative focal length change, k1 change.
inline constexpr int kWebcamParams = 8;
WebcamModel adjusted(const WebcamModel& base, const std::array<double, kWebcamParams>& d);

}  // namespace scaratwin
