// Colour recognition: camera projection round trip, and cubes drawn through the camera model
// into a synthetic picture are found at their positions (the rendered-picture check against
// MuJoCo lives in the hub tests).
#include <cmath>

#include <gtest/gtest.h>

#include "scaratwin/vision/vision.hpp"

namespace scaratwin {
namespace {

TEST(Camera, ProjectAndUnprojectAreInverse) {
  const RobotModel m = paper_robot();
  for (double x : {0.05, 0.15, 0.25}) {
    for (double y : {-0.12, 0.0, 0.1}) {
      double c, r;
      ASSERT_TRUE(project(m.scene.camera, {x, y, -0.01}, c, r));
      std::array<double, 3> p;
      ASSERT_TRUE(unproject_to_plane(m.scene.camera, c, r, -0.01, p));
      EXPECT_NEAR(p[0], x, 1e-12);
      EXPECT_NEAR(p[1], y, 1e-12);
    }
  }
  // the look-at point is the centre of the picture.
  double c, r;
  ASSERT_TRUE(project(m.scene.camera, m.scene.camera.look_at_m, c, r));
  EXPECT_NEAR(c, 320.0, 1e-9);
  EXPECT_NEAR(r, 240.0, 1e-9);
  EXPECT_FALSE(project(m.scene.camera, {0.15, 0.0, 1.0}, c, r));  // behind the camera
}

// Fills the convex quad of a cube's top face, as the camera sees it.
void draw_cube(RgbImage& img, const RobotModel& m, double x, double y, const uint8_t rgb[3]) {
  const double h = m.scene.cube_size_m / 2, z = m.scene.table_z_m + m.scene.cube_size_m;
  double cs[4], rs[4];
  const double dx[4] = {-h, h, h, -h}, dy[4] = {-h, -h, h, h};
  for (int i = 0; i < 4; ++i)
    ASSERT_TRUE(project(m.scene.camera, {x + dx[i], y + dy[i], z}, cs[i], rs[i]));
  for (int row = 0; row < img.height; ++row) {
    for (int col = 0; col < img.width; ++col) {
      const double pc = col + 0.5, pr = row + 0.5;
      bool inside = true;
      double sign = 0.0;
      for (int i = 0; i < 4; ++i) {
        const int j = (i + 1) % 4;
        const double cr = (cs[j] - cs[i]) * (pr - rs[i]) - (rs[j] - rs[i]) * (pc - cs[i]);
        if (sign == 0.0) sign = cr;
        if (cr * sign < 0.0) inside = false;
      }
      if (inside) {
        for (int k = 0; k < 3; ++k) img.rgb[3 * (row * img.width + col) + k] = rgb[k];
      }
    }
  }
}

TEST(Vision, FindsEachColouredCubeWhereItLies) {
  const RobotModel m = paper_robot();
  RgbImage img{640, 480, std::vector<uint8_t>(640 * 480 * 3, 180)};
  const uint8_t red[3] = {215, 20, 20}, green[3] = {20, 165, 30}, blue[3] = {20, 50, 230};
  const uint8_t tray[3] = {190, 140, 140};  // a pale tray must not count as a red cube
  draw_cube(img, m, 0.10, -0.14, tray);
  draw_cube(img, m, 0.18, 0.08, red);
  draw_cube(img, m, 0.14, 0.05, green);
  draw_cube(img, m, 0.21, 0.11, blue);
  const auto found = detect_cubes(img, m);
  ASSERT_EQ(found.size(), 3u);
  EXPECT_EQ(found[0].color, CubeColor::kRed);
  EXPECT_NEAR(found[0].x_m, 0.18, 0.0015);
  EXPECT_NEAR(found[0].y_m, 0.08, 0.0015);
  EXPECT_EQ(found[1].color, CubeColor::kGreen);
  EXPECT_NEAR(found[1].x_m, 0.14, 0.0015);
  EXPECT_NEAR(found[1].y_m, 0.05, 0.0015);
  EXPECT_EQ(found[2].color, CubeColor::kBlue);
  EXPECT_NEAR(found[2].x_m, 0.21, 0.0015);
  EXPECT_NEAR(found[2].y_m, 0.11, 0.0015);
  EXPECT_GT(found[0].area_px, 50);
}

// A magenta disc of radius 6 px centred at (cx, cy) on grey, drawn by pixel centres.
RgbImage disc_picture(double cx, double cy) {
  RgbImage img{120, 90, std::vector<std::uint8_t>(120 * 90 * 3, 90)};
  for (int v = 0; v < img.height; ++v) {
    for (int u = 0; u < img.width; ++u) {
      if (std::hypot(u + 0.5 - cx, v + 0.5 - cy) > 6.0) continue;
      std::uint8_t* p = &img.rgb[3 * (static_cast<std::size_t>(v) * img.width + u)];
      p[0] = 230;
      p[1] = 30;
      p[2] = 220;
    }
  }
  return img;
}

TEST(Vision, FindsAMarkerDiscAtItsCentreAndNotOneCutByTheEdge) {
  double col = 0.0, row = 0.0;
  ASSERT_TRUE(detect_marker(disc_picture(40.0, 30.0), col, row));
  EXPECT_NEAR(col, 40.0, 1e-9);  // symmetric about its centre: the centroid is exact
  EXPECT_NEAR(row, 30.0, 1e-9);
  // its centre 2 px inside the left edge: a third of it cut away, the centroid would be
  // 2.6 px off; not seen rather than seen wrong
  EXPECT_FALSE(detect_marker(disc_picture(2.0, 30.0), col, row));
  EXPECT_FALSE(detect_marker(disc_picture(60.0, 87.0), col, row));
  // one pixel clear of the edge: seen
  ASSERT_TRUE(detect_marker(disc_picture(8.0, 30.0), col, row));
  EXPECT_NEAR(col, 8.0, 1e-9);
}

TEST(Vision, RejectsBytesThatAreNotPng) {
  auto r = decode_png("definitely not a png");
  ASSERT_FALSE(r);
  EXPECT_NE(r.error().message.find("not a PNG"), std::string::npos);
}

}  // namespace
}  // namespace scaratwin
