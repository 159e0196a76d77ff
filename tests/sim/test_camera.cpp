// The overhead camera: headless EGL rendering, PNG round trip, and each cube's colour where
// the camera model projects its centre.
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <numbers>
#include <string>

#include <unistd.h>

#include <gtest/gtest.h>

#include "scaratwin/config/robot_config.hpp"
#include "scaratwin/core/units.hpp"
#include "scaratwin/sim/camera.hpp"
#include "scaratwin/sim/simulation.hpp"
#include "scaratwin/vision/vision.hpp"

namespace scaratwin::sim {
namespace {

struct Rgb {
  int r, g, b;
};

Rgb pixel(const RgbImage& img, double u, double v) {
  const int x = static_cast<int>(u), y = static_cast<int>(v);
  const std::uint8_t* p = img.rgb.data() + (static_cast<std::size_t>(y) * img.width + x) * 3;
  return {p[0], p[1], p[2]};
}

// The dominant channel of a clearly coloured pixel, or -1 for a greyish one.
int dominant(Rgb c) {
  const int v[3] = {c.r, c.g, c.b};
  const int i = static_cast<int>(std::max_element(v, v + 3) - v);
  for (int k = 0; k < 3; ++k) {
    if (k != i && v[i] < 2 * v[k] + 10) return -1;
  }
  return i;
}

class SimCamera : public ::testing::Test {
 protected:
  void SetUp() override {
    auto m = load_robot_config(SCARATWIN_CONFIG_FILE);
    ASSERT_TRUE(m.ok());
    robot_ = *m;
    SimOptions o;
    o.mjcf.offscreen_width_px = 800;
    o.mjcf.offscreen_height_px = 600;
    auto s = Simulation::create(robot_, o);
    ASSERT_TRUE(s.ok()) << s.error().message;
    sim_ = std::move(*s);
    auto c = Camera::create(*sim_);
    ASSERT_TRUE(c.ok()) << c.error().message;
    camera_ = std::move(*c);
    // the arm raised and turned aside so that it hides no cube
    ASSERT_TRUE(sim_->set_joints({0.12, deg_to_rad(115.0), 0.0, 0.0}).ok());
  }

  RobotModel robot_;
  std::unique_ptr<Simulation> sim_;
  std::unique_ptr<Camera> camera_;
};

TEST_F(SimCamera, PngDecodesWithTheConfiguredSizeAndCubesWhereProjected) {
  const double spots[kNumColors][2] = {{0.24, 0.1}, {0.15, 0.03}, {0.06, -0.06}};
  std::vector<CubeState> cubes;
  for (int c = 0; c < kNumColors; ++c) {
    auto cube = sim_->spawn_cube(CubeColor(c), spots[c][0], spots[c][1], 0.4 * c);
    ASSERT_TRUE(cube.ok()) << cube.error().message;
  }
  ASSERT_TRUE(sim_->step(250).ok());
  const CameraModel& cm = robot_.scene.camera;
  for (auto [w, h] : {std::pair{cm.width_px, cm.height_px}, std::pair{320, 200}}) {
    auto img = camera_->render(*sim_, w, h);
    ASSERT_TRUE(img.ok()) << img.error().message;
    auto png = encode_png(*img);
    ASSERT_TRUE(png.ok()) << png.error().message;
    ASSERT_GT(png->size(), 8u);
    EXPECT_EQ((*png)[1], 'P');
    auto decoded = decode_png(*png);
    ASSERT_TRUE(decoded.ok()) << decoded.error().message;
    EXPECT_EQ(decoded->width, w);
    EXPECT_EQ(decoded->height, h);
    EXPECT_EQ(decoded->rgb, img->rgb);  // lossless
    for (const CubeState& c : sim_->cubes()) {
      const PixelPoint p = project(cm, w, h, c.pos_m);
      ASSERT_TRUE(p.visible) << color_name(c.color);
      const Rgb px = pixel(*decoded, p.u_px, p.v_px);
      EXPECT_EQ(dominant(px), static_cast<int>(c.color))
          << color_name(c.color) << " cube at (" << p.u_px << ", " << p.v_px << ") px in " << w
          << "x" << h << " looks " << px.r << "," << px.g << "," << px.b;
    }
    // and the bare table between them is not mistaken for a cube
    const PixelPoint t = project(cm, w, h, {0.2, 0.2, robot_.scene.table_z_m});
    ASSERT_TRUE(t.visible);
    EXPECT_EQ(dominant(pixel(*decoded, t.u_px, t.v_px)), -1);
  }
}

TEST_F(SimCamera, RejectsSizesBeyondTheBufferAndSavesFiles) {
  auto too_big = camera_->render(*sim_, 801, 600);
  ASSERT_FALSE(too_big.ok());
  EXPECT_NE(too_big.error().message.find("801x600"), std::string::npos);
  EXPECT_FALSE(camera_->render(*sim_, 0, 10).ok());
  auto img = camera_->render(*sim_, 64, 48);
  ASSERT_TRUE(img.ok());
  const auto path = std::filesystem::temp_directory_path() /
                    ("scaratwin_test_camera_" + std::to_string(::getpid()) + ".png");
  ASSERT_TRUE(save_png(*img, path.string()).ok());
  EXPECT_GT(std::filesystem::file_size(path), 8u);
  std::filesystem::remove(path);
  EXPECT_FALSE(decode_png(std::vector<std::uint8_t>{1, 2, 3}).ok());
}

// Both markers at every wrist angle, in both elbow configurations, high and low: each is seen
// where project() puts marker_position() / flag_marker_position() (a rendered disc's centroid:
// within 0.3 px at 800x600; measured 0.13 px magenta, 0.21 px cyan), the cyan disc is never hidden
// (at least 80 % of its projected area is cyan), and neither is taken for a cube.
TEST_F(SimCamera, BothMarkersAreSeenWhereProjectedAtEveryWristAngle) {
  const CameraModel& cm = robot_.scene.camera;
  const int w = 800, h = 600;
  const double f_px = 0.5 * h / std::tan(0.5 * deg_to_rad(cm.fovy_deg));
  const double arm[][2] = {{0, 60}, {30, -60}, {-45, 90}, {80, -70}, {-90, 120}};
  double worst[2] = {0, 0}, least_area = 1e9;
  for (double d1 : {0.12, 0.01}) {
    for (const auto& a : arm) {
      for (int j4 = 0; j4 <= 180; j4 += 15) {
        const JointVector q{d1, deg_to_rad(a[0]), deg_to_rad(a[1]), deg_to_rad(j4)};
        ASSERT_TRUE(sim_->set_joints(q).ok());
        auto img = camera_->render(*sim_, w, h);
        ASSERT_TRUE(img.ok()) << img.error().message;
        const RgbImage rgb{img->width_px, img->height_px, img->rgb};
        const std::array<double, 3> at[2] = {marker_position(robot_, q),
                                             flag_marker_position(robot_, q)};
        for (int k = 0; k < 2; ++k) {
          double col = 0, row = 0;
          const bool seen =
              k == 0 ? detect_marker(rgb, col, row) : detect_flag_marker(rgb, col, row);
          ASSERT_TRUE(seen) << "marker " << k << " at " << a[0] << "," << a[1] << "," << j4;
          const PixelPoint p = project(cm, w, h, at[k]);
          worst[k] = std::max(worst[k], std::hypot(col - p.u_px, row - p.v_px));
        }
        // the cyan disc's visible area against its projected area
        int cyan = 0;
        for (std::size_t i = 0; i < rgb.rgb.size(); i += 3) {
          cyan += rgb.rgb[i + 1] > 115 && rgb.rgb[i + 2] > 115 &&
                  rgb.rgb[i] < 0.6 * std::min(rgb.rgb[i + 1], rgb.rgb[i + 2]);
        }
        const double depth = cm.pos_m[2] - at[1][2];
        const double r_px = f_px * kFlagMarkerRadiusM / depth;
        least_area = std::min(least_area, cyan / (std::numbers::pi * r_px * r_px));
        EXPECT_TRUE(detect_cubes(rgb, robot_).empty()) << a[0] << "," << a[1] << "," << j4;
      }
    }
  }
  std::printf(
      "marker centroid vs projection: magenta %.3f px, cyan %.3f px; least cyan area %.2f\n",
      worst[0], worst[1], least_area);
  EXPECT_LT(worst[0], 0.3);
  EXPECT_LT(worst[1], 0.3);
  EXPECT_GT(least_area, 0.8);
}

// A camera turned about its optical axis: MuJoCo renders each cube where project() puts it,
// and that is not where the unturned model would (so both the MJCF and project() must honour
// the roll; dropping it from either fails).
TEST(SimCameraRoll, CubesAreWhereTheTurnedCameraProjectsThem) {
  auto m = load_robot_config(SCARATWIN_CONFIG_FILE);
  ASSERT_TRUE(m.ok());
  RobotModel robot = *m;
  robot.scene.camera.roll_rad = deg_to_rad(25.0);
  auto sim = Simulation::create(robot);
  ASSERT_TRUE(sim.ok()) << sim.error().message;
  auto cam = Camera::create(**sim);
  ASSERT_TRUE(cam.ok()) << cam.error().message;
  ASSERT_TRUE((*sim)->set_joints({0.12, deg_to_rad(115.0), 0.0, 0.0}).ok());
  const double spots[kNumColors][2] = {{0.27, 0.12}, {0.15, 0.16}, {0.03, -0.12}};
  for (int c = 0; c < kNumColors; ++c) {
    ASSERT_TRUE((*sim)->spawn_cube(CubeColor(c), spots[c][0], spots[c][1], 0.0).ok());
  }
  ASSERT_TRUE((*sim)->step(250).ok());
  const CameraModel& turned = robot.scene.camera;
  CameraModel upright = turned;
  upright.roll_rad = 0.0;
  auto img = (*cam)->render(**sim, turned.width_px, turned.height_px);
  ASSERT_TRUE(img.ok()) << img.error().message;
  auto png = encode_png(*img);
  ASSERT_TRUE(png.ok());
  auto decoded = decode_png(*png);
  ASSERT_TRUE(decoded.ok());
  for (const CubeState& c : (*sim)->cubes()) {
    const PixelPoint p = project(turned, turned.width_px, turned.height_px, c.pos_m);
    ASSERT_TRUE(p.visible) << color_name(c.color);
    const Rgb px = pixel(*decoded, p.u_px, p.v_px);
    EXPECT_EQ(dominant(px), static_cast<int>(c.color))
        << color_name(c.color) << " cube at (" << c.pos_m[0] << ", " << c.pos_m[1] << ", "
        << c.pos_m[2] << ") m, seen at (" << p.u_px << ", " << p.v_px << ") px, looks " << px.r
        << "," << px.g << "," << px.b;
    const PixelPoint q = project(upright, turned.width_px, turned.height_px, c.pos_m);
    EXPECT_GT(std::hypot(p.u_px - q.u_px, p.v_px - q.v_px), 30.0) << color_name(c.color);
  }
}

}  // namespace
}  // namespace scaratwin::sim
