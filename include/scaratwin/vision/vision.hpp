// Colour recognition for the sorting task (the paper's MATLAB vision step): decode the overhead
// camera's PNG, find the red, green and blue cubes as connected blobs of saturated colour, and
// place each on the table through the pinhole model of the camera in the robot description.
// Pure: bytes in, detections out (no file or network I/O).
//
// Image convention: row 0 is the top of the picture; pixel (col, row) covers [col, col + 1) x
// [row, row + 1). Camera frame (as MuJoCo's): x to the right of the image, y up, looking along
// -z. Positions are in the robot base frame B, metres.
#pragma once

#include <array>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "scaratwin/core/result.hpp"
#include "scaratwin/kinematics/robot_model.hpp"

namespace scaratwin {

struct RgbImage {
  int width = 0;
  int height = 0;
  std::vector<std::uint8_t> rgb;  // width * height * 3, row 0 at the top
};

// Decodes PNG bytes (8-bit RGB or RGBA, or anything libpng can expand to it).
Result<RgbImage> decode_png(std::span<const std::uint8_t> png_bytes);
Result<RgbImage> decode_png(const std::string& png_bytes);

// Axes of the overhead camera in B, as MuJoCo cameras use them: x to the right of the image,
// y up in the image, the camera looking along -z. Derived from pos_m and look_at_m (the image
// "up" is +z of B projected, or +x of B when the camera looks straight down), then turned by
// roll_rad about z. The simulator's MJCF places its camera with these.
struct CameraAxes {
  std::array<double, 3> x{}, y{}, z{};
};
CameraAxes camera_axes(const CameraModel& camera);

// Pixel (continuous column, row) of a point in B in a picture of the camera's nominal size,
// or of width_px x height_px (the intrinsics scale with the height: MuJoCo's symmetric
// frustum of vertical field of view fovy); false when behind the camera.
bool project(const CameraModel& camera, const std::array<double, 3>& p_B, double& col, double& row);
bool project(const CameraModel& camera, int width_px, int height_px,
             const std::array<double, 3>& p_B, double& col, double& row);

// Point of the horizontal plane z = plane_z_m seen at pixel (col, row); false when the ray
// misses it.
bool unproject_to_plane(const CameraModel& camera, double col, double row, double plane_z_m,
                        std::array<double, 3>& p_B);

struct CubeDetection {
  CubeColor color = CubeColor::kRed;
  double col = 0.0, row = 0.0;  // blob centroid (pixels)
  int area_px = 0;
  double x_m = 0.0, y_m = 0.0;  // cube centre on the table, in B
};

struct DetectOptions {
  int min_area_px = 12;       // smaller blobs are noise
  double min_channel = 0.30;  // the dominant channel must exceed this (0..1)
  double dominance = 1.8;     // and exceed the other two by this factor
};

// Finds the cubes in a picture taken by `camera` (the picture may be of another size than the
// camera's nominal one: the intrinsics scale with it). Sorted by colour, then by area.
std::vector<CubeDetection> detect_cubes(const RgbImage& image, const RobotModel& model,
                                        const DetectOptions& options = {});

// The robot's tracking marker (a magenta disc on the wrist axis): the centroid of the magenta
// pixels (red and blue both at least `min_channel` of full scale and green below `green_ratio`
// of the smaller of them), in pixels; false when fewer than `min_area_px` are found or the
// disc touches the picture's edge (cut by it, its centroid would be off its centre).
bool detect_marker(const RgbImage& image, double& col, double& row, int min_area_px = 4,
                   double min_channel = 0.45, double green_ratio = 0.6);

// The second marker (a cyan disc on a flag off the wrist axis, showing the wrist's angle): the
// centroid of the cyan pixels (green and blue both at least `min_channel` of full scale and
// red below `red_ratio` of the smaller of them); false when fewer than `min_area_px` or on the
// picture's edge.
bool detect_flag_marker(const RgbImage& image, double& col, double& row, int min_area_px = 4,
                        double min_channel = 0.45, double red_ratio = 0.6);

}  // namespace scaratwin
