// The real camera over the physical table: a webcam on its own as-built mount (the plant's
// as-built scene camera), rendered from the plant's world, then spoilt the way a cheap lens and
// sensor spoil a picture: radial lens distortion, an exposure gain and sensor noise (seeded:
// the same frame number gives the same noise). On a real robot a V4L2 webcam takes its place.
#pragma once

#include <cstdint>
#include <memory>

#include "scaratwin/core/result.hpp"
#include "scaratwin/plant/plant.hpp"
#include "scaratwin/sim/camera.hpp"

namespace scaratwin::plant {

struct LensModel {
  double k1 = -0.06;         // radial distortion (barrel < 0) at the image's half-height
  double gain = 0.95;        // exposure: pixel values scale by this
  double noise_sigma = 2.0;  // sensor noise, standard deviation in 0..255 units
  std::uint64_t seed = 1;
};

class PlantCamera {
 public:
  static Result<std::unique_ptr<PlantCamera>> create(const Plant& plant,
                                                     const LensModel& lens = {});
  ~PlantCamera();
  // A picture of the physical table now, width x height (at most kWebcamScale times the scene
  // camera's size).
  Result<sim::Image> grab(const Plant& plant, int width_px, int height_px);
  std::uint64_t frames() const { return frames_; }

 private:
  PlantCamera() = default;
  std::unique_ptr<sim::Camera> camera_;
  LensModel lens_;
  std::uint64_t frames_ = 0;
};

// The lens and sensor applied to a rendered picture (pure; `frame` seeds the noise).
sim::Image spoil(const sim::Image& ideal, const LensModel& lens, std::uint64_t frame);

}  // namespace scaratwin::plant
