// The fixed overhead camera of the virtual scene: offscreen rendering with MuJoCo's renderer
// on an EGL context of Mesa's surfaceless platform (no display, no GPU needed), PNG encoding
// with libpng, and where a point of the scene appears in a picture (the pinhole model of
// scaratwin::vision, with the visibility test).
//
// Images are 8-bit RGB, row 0 at the top (MuJoCo reads pixels bottom-up; we flip them).
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "scaratwin/core/result.hpp"
#include "scaratwin/kinematics/robot_model.hpp"

namespace scaratwin::sim {

class Simulation;

struct Image {
  int width_px = 0;
  int height_px = 0;
  std::vector<std::uint8_t> rgb;  // width * height * 3, row 0 at the top
};

struct RenderOptions {
  bool shadows = false;  // shadows cost about 3x the render time on llvmpipe
};

// One EGL context and MuJoCo render context for a model. Thread-safe: render() may be called
// from any thread (it makes the context current for the call and releases it after).
class Camera {
 public:
  // Creates the context for `sim`'s model. The largest image is the model's offscreen size
  // (MjcfOptions::offscreen_width_px / height_px). Errors: no EGL display or config, GL context
  // failure, MuJoCo error.
  static Result<std::unique_ptr<Camera>> create(const Simulation& sim,
                                                const RenderOptions& options = {});
  ~Camera();
  Camera(const Camera&) = delete;
  Camera& operator=(const Camera&) = delete;

  // Two halves so that a caller can hold a lock on the simulation only while the scene is
  // captured: capture() copies the current poses into the renderer's scene; draw() renders
  // the last capture at width x height (1..max). render() does both.
  Status capture(const Simulation& sim);
  Result<Image> draw(int width_px, int height_px);
  Result<Image> render(const Simulation& sim, int width_px, int height_px);

  int max_width_px() const;
  int max_height_px() const;

 private:
  Camera();
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// PNG of an RGB image. `level` is the zlib level 0..9 (1: fast, about half the raw size for
// these scenes). Errors: bad image size, libpng failure.
Result<std::vector<std::uint8_t>> encode_png(const Image& image, int level = 1);
// (Decoding: scaratwin::decode_png, include/scaratwin/vision/vision.hpp.)
Status save_png(const Image& image, const std::string& path, int level = 1);

// Where a point p (in B, metres) appears in a width x height picture of the camera model:
// column u and row v in pixels from the top-left corner (pixel centres at +0.5). `visible` is
// false behind the camera or outside the picture.
struct PixelPoint {
  double u_px = 0.0;
  double v_px = 0.0;
  bool visible = false;
};
PixelPoint project(const CameraModel& camera, int width_px, int height_px,
                   const std::array<double, 3>& p_m);

}  // namespace scaratwin::sim
