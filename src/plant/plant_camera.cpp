#include "scaratwin/plant/plant_camera.hpp"

#include <algorithm>
#include <cmath>

namespace scaratwin::plant {

PlantCamera::~PlantCamera() = default;

Result<std::unique_ptr<PlantCamera>> PlantCamera::create(const Plant& plant,
                                                         const LensModel& lens) {
  auto cam = sim::Camera::create(plant.world());
  if (!cam) return cam.error();
  std::unique_ptr<PlantCamera> p(new PlantCamera());
  p->camera_ = std::move(cam).value();
  p->lens_ = lens;
  return p;
}

Result<sim::Image> PlantCamera::grab(const Plant& plant, int width_px, int height_px) {
  auto img = camera_->render(plant.world(), width_px, height_px);
  if (!img) return img.error();
  return spoil(*img, lens_, frames_++);
}

namespace {

std::uint64_t mix(std::uint64_t z) {
  z += 0x9E3779B97F4A7C15ULL;
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
  return z ^ (z >> 31);
}

}  // namespace

sim::Image spoil(const sim::Image& ideal, const LensModel& lens, std::uint64_t frame) {
  sim::Image out;
  out.width_px = ideal.width_px;
  out.height_px = ideal.height_px;
  out.rgb.resize(ideal.rgb.size());
  const double cx = 0.5 * ideal.width_px, cy = 0.5 * ideal.height_px;
  const double norm = 0.5 * ideal.height_px;
  std::uint64_t state = mix(lens.seed ^ (frame * 0x100000001B3ULL));
  for (int v = 0; v < out.height_px; ++v) {
    for (int u = 0; u < out.width_px; ++u) {
      // where this pixel's ray lands on the ideal (pinhole) picture
      const double x = (u + 0.5 - cx) / norm, y = (v + 0.5 - cy) / norm;
      const double s = 1.0 + lens.k1 * (x * x + y * y);
      // bilinear between the four ideal pixels around the point (their centres at +0.5)
      const double qu = cx + x * s * norm - 0.5, qv = cy + y * s * norm - 0.5;
      const int su = static_cast<int>(std::floor(qu)), sv = static_cast<int>(std::floor(qv));
      const double fu = qu - su, fv = qv - sv;
      std::uint8_t* o = &out.rgb[3 * (static_cast<std::size_t>(v) * out.width_px + u)];
      const bool inside = su >= 0 && sv >= 0 && su + 1 < ideal.width_px && sv + 1 < ideal.height_px;
      for (int c = 0; c < 3; ++c) {
        double src = 0.0;
        if (inside) {
          const auto at = [&](int a, int b) {
            return static_cast<double>(
                ideal.rgb[3 * (static_cast<std::size_t>(b) * ideal.width_px + a) + c]);
          };
          src = (1 - fv) * ((1 - fu) * at(su, sv) + fu * at(su + 1, sv)) +
                fv * ((1 - fu) * at(su, sv + 1) + fu * at(su + 1, sv + 1));
        }
        // noise: a sum of two uniforms, scaled to the wanted standard deviation
        state = mix(state);
        const double u1 = static_cast<double>(state >> 11) * 0x1.0p-53;
        state = mix(state);
        const double u2 = static_cast<double>(state >> 11) * 0x1.0p-53;
        const double noise = (u1 + u2 - 1.0) * lens.noise_sigma * 2.449489742783178;
        o[c] = static_cast<std::uint8_t>(std::clamp(src * lens.gain + noise, 0.0, 255.0));
      }
    }
  }
  return out;
}

}  // namespace scaratwin::plant
