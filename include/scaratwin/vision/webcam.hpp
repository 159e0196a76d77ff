// The physical webcam over the table and its calibration from the printed pattern. The virtual
// scene camera (CameraModel) stays an ideal pinhole; a real webcam sits where its mount put it
// and bends straight lines (radial lens distortion). This module models it (WebcamModel), finds
// the pattern's AprilTags in its pictures (libapriltag, family tag36h11), and fits its pose,
// focal length and distortion to the tag corners by nonlinear least squares (Eigen's
// Levenberg-Marquardt). It also draws the pattern (the texture the emulated plant prints on its
// table). Pure: images and numbers in, numbers out (no I/O).
//
// Image convention as vision.hpp: row 0 at the top, pixel (col, row) covers [col, col + 1) x
// [row, row + 1), so pixel centres are at +0.5. Camera frame as MuJoCo's: x to the right of the
// picture, y up, looking along -z. Positions in the robot base frame B, metres.
#pragma once

#include <array>
#include <string>
#include <vector>

#include "scaratwin/core/result.hpp"
#include "scaratwin/kinematics/robot_model.hpp"
#include "scaratwin/vision/vision.hpp"

namespace scaratwin {

// --- the printed pattern ---------------------------------------------------------------------

// One tag of the pattern: its id and its four corners in B (m), in the order detect_tags()
// reports them: the black square's corners at the board's (-x, -y), (+x, -y), (+x, +y),
// (-x, +y) sides (counter-clockwise seen from above).
struct PatternTag {
  int id = 0;
  std::array<std::array<double, 3>, 4> p_B{};
};
// Every tag of the description's pattern (scene.pattern), lying on the table (z = table_z_m +
// thickness_m).
std::vector<PatternTag> pattern_corners(const RobotModel& model);

// The printed sheet as a picture: the board's black squares and white borders with a white
// margin of one tag cell around the outermost tags. Row 0 is the board's +y edge, column 0 its
// -x edge (the sheet seen from above, the board's x to the right). Each tag cell is
// `texels_per_cell` pixels (at most 4096 pixels each way).
// The sheet's size (m): along the board's x, along its y.
std::array<double, 2> pattern_sheet_size_m(const PatternModel& pattern);
struct PatternSheet {
  RgbImage image;
  double width_m = 0.0;   // along the board's x
  double height_m = 0.0;  // along its y
};
Result<PatternSheet> pattern_sheet(const PatternModel& pattern, int texels_per_cell = 8);

// --- the webcam ------------------------------------------------------------------------------

// The physical webcam, calibrated.
struct WebcamModel {
  std::array<double, 3> pos_m{};  // optical centre in B
  std::array<double, 9> r_bc{};   // rotation B <- camera, row-major (columns: camera x, y, z in B)
  double f_px = 0, cx_px = 0, cy_px = 0;  // focal length and principal point at width x height
  // Radial distortion on normalised coordinates (x/-z, y/-z), in the undistorting direction:
  // a point seen at distorted normalised coordinates d lies on the ray of d * (1 + k1 |d|^2 +
  // k2 |d|^4). (The inverse of the Brown polynomial; the same family, with the advantage that
  // unprojecting a pixel is closed-form. project() inverts it by Newton's method.)
  double k1 = 0, k2 = 0;
  int width_px = 640, height_px = 480;
};

// The ideal camera of the description: pinhole, no distortion, from its pose, fovy and size.
WebcamModel nominal_webcam(const CameraModel& camera);

// Pixel (col, row) of a point in B in a picture of width_px x height_px (the intrinsics scale
// with the height about the picture's centre); false behind the camera or where the lens model
// cannot be inverted (far outside the picture).
bool project(const WebcamModel& camera, const std::array<double, 3>& p_B, int width_px,
             int height_px, double& col, double& row);
// Where the centroid of the picture of a horizontal disc (a marker: centre in B, radius in m)
// falls: perspective and the lens shift it off the centre's own projection (0.4 px at
// 1280x960 for the 6 mm markers near the picture's edge). False when not all of it projects.
bool project_disc(const WebcamModel& camera, const std::array<double, 3>& centre_B, double radius_m,
                  int width_px, int height_px, double& col, double& row);
// Point of the horizontal plane z = plane_z_m seen at pixel (col, row); false when the ray
// misses it.
bool unproject_to_plane(const WebcamModel& camera, double col, double row, int width_px,
                        int height_px, double plane_z_m, std::array<double, 3>& p_B);

// The calibration's parameters: position change (3, m, in B), a small rotation vector in the
// camera frame (3, rad: r_bc becomes r_bc * exp([w])), the relative focal length change and
// the change of k1.
inline constexpr int kWebcamParams = 8;
using WebcamParams = std::array<double, kWebcamParams>;
WebcamModel adjusted(const WebcamModel& base, const WebcamParams& d);
// The change that takes `base` to `camera` (the focal lengths compared at the same picture
// height): adjusted(base, adjustment(base, c)) is c for cameras that differ in these only.
WebcamParams adjustment(const WebcamModel& base, const WebcamModel& camera);

// --- the tags in a picture and the fit -------------------------------------------------------

struct TagCorners {
  int id = 0;
  std::array<std::array<double, 2>, 4> px{};  // (col, row) of each corner, sub-pixel
};
// The tag36h11 tags in a picture, sorted by id (libapriltag, full resolution, edges refined;
// at most one corrected bit; tags with a corner within 3 px of the picture's edge are dropped:
// the edge cuts them).
std::vector<TagCorners> detect_tags(const RgbImage& image);

struct WebcamFitOptions {
  int min_tags = 4;         // fewer tags of the pattern seen: refused
  double max_rms_px = 1.0;  // a larger residual: refused (a misprinted pattern, a blur)
  // The focal length is fitted only when the corners determine it: when its variance inflation
  // (how much the other parameters' correlation with it multiplies its variance) stays below
  // this. A flat board seen square-on cannot tell a longer focal length from a higher camera.
  double max_focal_inflation = 100.0;
};

struct WebcamFit {
  WebcamModel camera;        // the fitted webcam
  double rms_px = 0.0;       // residual over the corners (pixels of the picture)
  double max_px = 0.0;       // largest corner residual
  int tags = 0;              // pattern tags used
  int corners = 0;           // corners used (4 per tag)
  WebcamParams params{};     // the fitted change from the guess
  WebcamParams std_error{};  // one standard error per parameter (0 for one held fixed)
  bool focal_fitted = false;
  double focal_inflation = 0.0;  // the variance inflation measured for the focal length
  std::string note;              // what was held fixed and why
};

// Fits the webcam to the tags seen in one picture of width_px x height_px of the description's
// pattern (pattern_corners(model)), starting from `guess` (e.g. nominal_webcam of the scene
// camera). Tags that are not on the pattern are ignored. Errors name the problem: too few
// pattern tags (code 70), a fit that did not converge (71), a residual above max_rms_px (72).
Result<WebcamFit> calibrate_webcam(const WebcamModel& guess, const std::vector<TagCorners>& tags,
                                   int width_px, int height_px, const RobotModel& model,
                                   const WebcamFitOptions& options = {});

}  // namespace scaratwin
