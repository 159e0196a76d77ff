// The webcam model and its calibration from the printed pattern: the lens model against its
// definition, the fit on synthetic corners (recovery, the focal length's observability, the
// refusals), and the real thing: the emulated plant's camera (a MuJoCo render of the as-built
// world, radial distortion, gain, noise) looking at the pattern and at the markers.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>

#include <gtest/gtest.h>

#include "../parameter_bounds.hpp"
#include "scaratwin/core/units.hpp"
#include "scaratwin/kinematics/physical.hpp"
#include "scaratwin/plant/plant.hpp"
#include "scaratwin/plant/plant_camera.hpp"
#include "scaratwin/sim/mjcf.hpp"
#include "scaratwin/vision/webcam.hpp"

namespace scaratwin {
namespace {

using Vec3 = std::array<double, 3>;

double distance_mm(const Vec3& a, const Vec3& b) {
  return 1e3 * std::hypot(a[0] - b[0], a[1] - b[1], a[2] - b[2]);
}

// Angle of the rotation between two cameras' orientations (deg).
double rotation_error_deg(const WebcamModel& a, const WebcamModel& b) {
  double tr = 0.0;  // trace of a^T b
  for (int i = 0; i < 9; ++i) tr += a.r_bc[i] * b.r_bc[i];
  return rad_to_deg(std::acos(std::clamp(0.5 * (tr - 1.0), -1.0, 1.0)));
}

TEST(Webcam, NominalIsTheSceneCamerasPinhole) {
  RobotModel m = paper_robot();
  m.scene.camera.roll_rad = deg_to_rad(7.0);
  m.scene.camera.look_at_m = {0.2, 0.05, -0.03};
  const WebcamModel w = nominal_webcam(m.scene.camera);
  EXPECT_EQ(w.k1, 0.0);
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> x(-0.05, 0.35), y(-0.2, 0.2), z(-0.03, 0.15);
  for (int i = 0; i < 200; ++i) {
    const Vec3 p{x(rng), y(rng), z(rng)};
    for (auto [wd, ht] : {std::pair{640, 480}, std::pair{1280, 960}, std::pair{320, 200}}) {
      double c1 = 0, r1 = 0, c2 = 0, r2 = 0;
      ASSERT_TRUE(project(m.scene.camera, wd, ht, p, c1, r1));
      ASSERT_TRUE(project(w, p, wd, ht, c2, r2));
      EXPECT_NEAR(c2, c1, 1e-9);
      EXPECT_NEAR(r2, r1, 1e-9);
    }
  }
}

TEST(Webcam, DistortionFollowsItsDefinition) {
  // looking straight down from 1 m: a point at (X, Y) on z = 0 has normalised coordinates
  // (-Y, X) (picture right is -y of B, up is +x); the picture shows it at the distorted radius
  // rho with rho (1 + k1 rho^2 + k2 rho^4) = |(X, Y)|
  CameraModel cam;
  cam.pos_m = {0, 0, 1};
  cam.look_at_m = {0, 0, 0};
  cam.fovy_deg = 60;
  WebcamModel w = nominal_webcam(cam);
  w.k1 = -0.3;
  w.k2 = 0.05;
  for (double r : {0.05, 0.2, 0.4, 0.55}) {
    const Vec3 p{0.6 * r, -0.8 * r, 0.0};
    double col = 0, row = 0;
    ASSERT_TRUE(project(w, p, 640, 480, col, row));
    const double xd = (col - 320.0) / w.f_px, yd = (240.0 - row) / w.f_px;
    const double rho = std::hypot(xd, yd);
    EXPECT_NEAR(rho * (1 + w.k1 * rho * rho + w.k2 * std::pow(rho, 4)), r, 1e-12);
    EXPECT_NEAR(xd / rho, 0.8, 1e-9);  // the direction is kept
    EXPECT_NEAR(yd / rho, 0.6, 1e-9);
    Vec3 back{};
    ASSERT_TRUE(unproject_to_plane(w, col, row, 640, 480, 0.0, back));
    EXPECT_NEAR(back[0], p[0], 1e-12);
    EXPECT_NEAR(back[1], p[1], 1e-12);
  }
  double c = 0, r = 0;
  EXPECT_FALSE(project(w, {0.0, 0.0, 2.0}, 640, 480, c, r));  // behind the camera
}

TEST(Webcam, AdjustedMovesTurnsAndScales) {
  const WebcamModel base = nominal_webcam(paper_robot().scene.camera);
  const double a = 0.01;
  const WebcamModel w = adjusted(base, {0.001, -0.002, 0.003, 0.0, 0.0, a, 0.02, -0.3});
  EXPECT_NEAR(
      distance_mm(w.pos_m, {base.pos_m[0] + 0.001, base.pos_m[1] - 0.002, base.pos_m[2] + 0.003}),
      0.0, 1e-9);
  // a turn about the camera's own z axis: new x = cos a x + sin a y
  for (int i = 0; i < 3; ++i) {
    EXPECT_NEAR(w.r_bc[3 * i], std::cos(a) * base.r_bc[3 * i] + std::sin(a) * base.r_bc[3 * i + 1],
                1e-12);
    EXPECT_NEAR(w.r_bc[3 * i + 2], base.r_bc[3 * i + 2], 1e-12);
  }
  EXPECT_DOUBLE_EQ(w.f_px, base.f_px * 1.02);
  EXPECT_DOUBLE_EQ(w.k1, -0.3);
  EXPECT_NEAR(rotation_error_deg(w, base), rad_to_deg(a), 1e-9);
  // and adjustment() reads the change back (adjusted() is checked by hand above)
  const WebcamParams back =
      adjustment(base, adjusted(base, {0.001, -0.002, 0.003, 0.004, -0.005, a, 0.02, -0.3}));
  const WebcamParams want{0.001, -0.002, 0.003, 0.004, -0.005, a, 0.02, -0.3};
  for (int i = 0; i < kWebcamParams; ++i) EXPECT_NEAR(back[i], want[i], 1e-12) << i;
}

TEST(Webcam, PatternCornersFollowTheDescription) {
  RobotModel m = paper_robot();
  m.scene.pattern.yaw_rad = deg_to_rad(90.0);
  const auto tags = pattern_corners(m);
  const PatternModel& p = m.scene.pattern;
  ASSERT_EQ(tags.size(), static_cast<std::size_t>(p.columns * p.rows));
  // tag 0: row 0 (the board's +y side), column 0 (its -x side); turned 90 deg, the board's x
  // is B's y and its y is B's -x
  const double pitch = p.tag_size_m + p.spacing_m;
  const double bx = -0.5 * (p.columns - 1) * pitch, by = 0.5 * (p.rows - 1) * pitch;
  const double h = 0.5 * p.tag_size_m;
  const Vec3 c0{p.x_m - (by - h), p.y_m + (bx - h), m.scene.table_z_m + p.thickness_m};
  EXPECT_LT(distance_mm(tags[0].p_B[0], c0), 1e-9);
  // each tag a square of the tag's size, corners counter-clockwise seen from above
  for (const PatternTag& t : tags) {
    for (int k = 0; k < 4; ++k) {
      const Vec3& a = t.p_B[k];
      const Vec3& b = t.p_B[(k + 1) % 4];
      const Vec3& c = t.p_B[(k + 2) % 4];
      EXPECT_NEAR(distance_mm(a, b), 1e3 * p.tag_size_m, 1e-9);
      EXPECT_GT((b[0] - a[0]) * (c[1] - b[1]) - (b[1] - a[1]) * (c[0] - b[0]), 0.0);
    }
  }
  // the sheet: ten cells per tag across plus one tag cell of margin
  auto sheet = pattern_sheet(p, 4);
  ASSERT_TRUE(sheet.ok());
  EXPECT_NEAR(sheet->width_m, p.columns * pitch - p.spacing_m + p.tag_size_m / 4, 1e-12);
  EXPECT_EQ(sheet->image.width,
            static_cast<int>(std::lround(sheet->width_m / (p.tag_size_m / 32))));
  EXPECT_FALSE(pattern_sheet(p, 200).ok());  // beyond 4096 pixels
}

// Synthetic corners: the pattern seen by `truth` through a straight-edged lens (k1 = k2 = 0:
// the detector's line intersections are then the corners' own projections), with seeded noise.
// The absolute bounds of docs/calibration.md in the fit's own units: position (m; one view's,
// kBoundOneViewMm), rotation (rad), the relative focal change (a fraction) and k1.
double webcam_bound(int i) {
  if (i < 3) return test::kBoundOneViewMm * 1e-3;
  if (i < 6) return test::kBoundDeg * M_PI / 180.0;
  if (i == 6) return test::kBoundPercent / 100.0;
  return test::kBoundK1;
}

std::vector<TagCorners> synthetic(const WebcamModel& truth, const RobotModel& m, double sigma_px,
                                  std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> noise(0.0, sigma_px);
  std::vector<TagCorners> out;
  for (const PatternTag& t : pattern_corners(m)) {
    TagCorners c;
    c.id = t.id;
    for (int k = 0; k < 4; ++k) {
      EXPECT_TRUE(project(truth, t.p_B[k], 1280, 960, c.px[k][0], c.px[k][1]));
      c.px[k][0] += noise(rng);
      c.px[k][1] += noise(rng);
    }
    out.push_back(c);
  }
  return out;
}

TEST(WebcamFit, RecoversASyntheticCameraAndHoldsTheUnobservableFocalLength) {
  const RobotModel m = paper_robot();
  const WebcamModel guess = nominal_webcam(m.scene.camera);
  const WebcamParams d{0.002, -0.003, 0.004, 0.01, -0.015, 0.02, 0.0, 0.0};
  const WebcamModel truth = adjusted(guess, d);
  auto fit = calibrate_webcam(guess, synthetic(truth, m, 0.1, 1), 1280, 960, m);
  ASSERT_TRUE(fit.ok()) << fit.error().message;
  EXPECT_FALSE(fit->focal_fitted);
  EXPECT_GT(fit->focal_inflation, 1e4);
  EXPECT_NE(fit->note.find("focal length held"), std::string::npos) << fit->note;
  EXPECT_EQ(fit->camera.f_px, guess.f_px);
  EXPECT_EQ(fit->std_error[6], 0.0);
  EXPECT_EQ(fit->corners, 80);
  EXPECT_NEAR(fit->rms_px, 0.1 * std::sqrt(2.0), 0.02);  // 0.1 px in each coordinate
  // every fitted parameter within 3 of its standard errors of the truth
  for (int i = 0; i < kWebcamParams; ++i) {
    if (i == 6) continue;
    EXPECT_GT(fit->std_error[i], 0.0) << i;
    EXPECT_LT(std::abs(fit->params[i] - d[i]), 3.0 * fit->std_error[i]) << i;
    EXPECT_LE(std::abs(fit->params[i] - d[i]), webcam_bound(i)) << i;
  }
}

TEST(WebcamFit, FitsTheFocalLengthWhenThePatternIsSeenObliquely) {
  // a camera off to the side looking at the board at 60 deg from above: depth varies across it
  RobotModel m = paper_robot();
  m.scene.camera.pos_m = {0.19, -0.3, 0.15};
  m.scene.camera.look_at_m = {0.19, 0.11, -0.03};
  const WebcamModel guess = nominal_webcam(m.scene.camera);
  const WebcamParams d{0.002, 0.001, -0.002, 0.004, 0.003, -0.005, 0.03, 0.0};
  auto fit = calibrate_webcam(guess, synthetic(adjusted(guess, d), m, 0.1, 2), 1280, 960, m);
  ASSERT_TRUE(fit.ok()) << fit.error().message;
  EXPECT_TRUE(fit->focal_fitted) << fit->note;
  EXPECT_LT(fit->focal_inflation, 100.0);
  EXPECT_GT(fit->std_error[6], 0.0);
  for (int i = 0; i < kWebcamParams; ++i) {
    EXPECT_LT(std::abs(fit->params[i] - d[i]), 3.0 * fit->std_error[i] + 1e-12) << i;
    EXPECT_LE(std::abs(fit->params[i] - d[i]), webcam_bound(i)) << i;
  }
}

TEST(WebcamFit, RefusesTooFewTagsAndAMovedPattern) {
  const RobotModel m = paper_robot();
  const WebcamModel guess = nominal_webcam(m.scene.camera);
  auto tags = synthetic(guess, m, 0.1, 3);
  // three tags of the pattern, plus tags that are not on it (ignored)
  std::vector<TagCorners> few(tags.begin(), tags.begin() + 3);
  for (int id : {100, 101, 102}) few.push_back(TagCorners{id, tags[5].px});
  auto r = calibrate_webcam(guess, few, 1280, 960, m);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, error_code(VisionError::kTooFewTags));
  EXPECT_NE(r.error().message.find("3 of the pattern's 20 tags seen (6 tags detected in all), "
                                   "at least 4 needed"),
            std::string::npos)
      << r.error().message;
  // printed with 20 mm gaps instead of the described 15 mm: no camera pose explains that
  RobotModel printed = m;
  printed.scene.pattern.spacing_m = 0.02;
  auto bad = calibrate_webcam(guess, synthetic(guess, printed, 0.1, 4), 1280, 960, m);
  ASSERT_FALSE(bad.ok());
  EXPECT_EQ(bad.error().code, error_code(VisionError::kResidualTooLarge));
  EXPECT_NE(bad.error().message.find("does the printed pattern match the description"),
            std::string::npos)
      << bad.error().message;
  // the same corners with the description that matches them: accepted
  EXPECT_TRUE(calibrate_webcam(guess, synthetic(guess, printed, 0.1, 4), 1280, 960, printed).ok());
}

// --- against the emulated plant's camera ------------------------------------------------------

RgbImage to_rgb(const sim::Image& i) { return RgbImage{i.width_px, i.height_px, i.rgb}; }

// The plant of a seeded as-built robot; the arm parked over the trays, clear of the pattern.
struct Bench {
  RobotModel description = paper_robot();
  AsBuilt as_built;
  plant::LensModel lens;
  std::unique_ptr<plant::Plant> plant;
  std::unique_ptr<plant::PlantCamera> camera;

  explicit Bench(std::uint64_t seed, const plant::LensModel& l = {}) : lens(l) {
    AsBuiltProfile profile;
    profile.seed = seed;
    as_built = draw_as_built(profile);
    plant::PlantOptions o;
    o.start_given = true;
    o.start = {0.12, deg_to_rad(-100.0), deg_to_rad(20.0), 0.0};
    plant = plant::Plant::create(description, as_built, o).value();
    camera = plant::PlantCamera::create(*plant, lens).value();
  }
  // The camera as truly built, in the webcam model: the as-built mount (as_built_robot()), and
  // the lens's distortion moved from the plant's half-height units to focal-length units.
  WebcamModel truth() const {
    const CameraModel cam = plant::as_built_robot(description, as_built).scene.camera;
    WebcamModel w = nominal_webcam(cam);
    const double t = std::tan(0.5 * deg_to_rad(cam.fovy_deg));
    w.k1 = lens.k1 / (t * t);
    return w;
  }
  RgbImage grab(int w = 1280, int h = 960) { return to_rgb(camera->grab(*plant, w, h).value()); }
};

TEST(WebcamPlant, TheRenderedPatternsCornersAreWhereTheDescriptionPutsThem) {
  // a lens without distortion: the detected corners are the corners' projections (within the
  // render's and the detector's accuracy: measured 0.04-0.15 px rms, 0.1-0.32 px max at
  // 1280x960 over seeds 3, 5, 11; this one is the worst)
  plant::LensModel straight;
  straight.k1 = 0.0;
  Bench b(11, straight);
  EXPECT_FALSE(b.plant->pattern_on());
  EXPECT_TRUE(detect_tags(b.grab()).empty());  // no pattern at power-up
  ASSERT_TRUE(b.plant->set_pattern(true).ok());
  const auto tags = detect_tags(b.grab());
  const auto pattern = pattern_corners(b.description);
  ASSERT_EQ(tags.size(), pattern.size());
  double worst = 0.0, sum2 = 0.0;
  for (const TagCorners& t : tags) {
    for (int k = 0; k < 4; ++k) {
      double col = 0, row = 0;
      ASSERT_TRUE(
          project(b.truth(), pattern[static_cast<std::size_t>(t.id)].p_B[k], 1280, 960, col, row));
      const double e = std::hypot(col - t.px[k][0], row - t.px[k][1]);
      worst = std::max(worst, e);
      sum2 += e * e;
    }
  }
  const double rms = std::sqrt(sum2 / (4.0 * static_cast<double>(tags.size())));
  std::printf("pattern corners vs true projection: rms %.3f px, max %.3f px\n", rms, worst);
  EXPECT_LT(rms, 0.2);
  EXPECT_LT(worst, 0.4);
  ASSERT_TRUE(b.plant->set_pattern(false).ok());
  EXPECT_TRUE(detect_tags(b.grab()).empty());
}

TEST(WebcamPlant, CalibrationRecoversTheAsBuiltCamera) {
  for (std::uint64_t seed : {3u, 5u, 11u}) {
    Bench b(seed);
    ASSERT_TRUE(b.plant->set_pattern(true).ok());
    const RgbImage img = b.grab();
    const WebcamModel guess = nominal_webcam(b.description.scene.camera);
    auto fit = calibrate_webcam(guess, detect_tags(img), img.width, img.height, b.description);
    ASSERT_TRUE(fit.ok()) << fit.error().message;
    const WebcamModel truth = b.truth();
    const double dp = distance_mm(fit->camera.pos_m, truth.pos_m);
    const double dr = rotation_error_deg(fit->camera, truth);
    std::printf(
        "seed %d: %d tags, rms %.3f px (max %.3f); camera off by %.3f mm, %.4f deg (nominal: "
        "%.2f mm, %.3f deg); k1 %.4f (true %.4f)\n",
        static_cast<int>(seed), fit->tags, fit->rms_px, fit->max_px, dp, dr,
        distance_mm(guess.pos_m, truth.pos_m), rotation_error_deg(guess, truth), fit->camera.k1,
        truth.k1);
    EXPECT_GE(fit->tags, 19);  // one may sit on the picture's edge
    EXPECT_LT(fit->rms_px, 0.2);
    EXPECT_FALSE(fit->focal_fitted);
    // measured 0.06-0.18 mm and 0.007-0.022 deg over these seeds, from 1.7-3.5 mm, 0.8-1.4 deg
    EXPECT_LT(dp, 0.25) << seed;
    EXPECT_LT(dr, 0.025) << seed;
    EXPECT_NEAR(fit->camera.k1, truth.k1, 0.003 * std::abs(truth.k1)) << seed;
  }
}

TEST(WebcamPlant, MarkersAreWhereTheCalibratedCameraProjectsThem) {
  Bench b(11);
  ASSERT_TRUE(b.plant->set_pattern(true).ok());
  const RgbImage board = b.grab();
  auto fit = calibrate_webcam(nominal_webcam(b.description.scene.camera), detect_tags(board),
                              board.width, board.height, b.description);
  ASSERT_TRUE(fit.ok()) << fit.error().message;
  // poses spread over the workspace, both elbows, wrist angles, high and low
  const double poses[][4] = {{0.12, 0, 60, 0},   {0.06, 30, -60, 90},   {0.02, -45, 90, 180},
                             {0.1, 80, -70, 45}, {0.04, -20, 100, 135}, {0.12, 60, -40, 30}};
  double worst_centre = 0, worst_disc = 0;
  for (const auto& q0 : poses) {
    plant::PlantOptions o;
    o.start_given = true;
    o.start = {q0[0], deg_to_rad(q0[1]), deg_to_rad(q0[2]), deg_to_rad(q0[3])};
    auto p = plant::Plant::create(b.description, b.as_built, o).value();
    auto cam = plant::PlantCamera::create(*p, b.lens).value();
    const RgbImage img = to_rgb(cam->grab(*p, 1280, 960).value());
    // the true joints and the robot as built (the truth, for this test only)
    const JointVector q = p->joints();
    const Vec3 at[2] = {sim::marker_position(p->built(), q),
                        sim::flag_marker_position(p->built(), q)};
    const double radius[2] = {sim::kMarkerRadiusM, sim::kFlagMarkerRadiusM};
    for (int k = 0; k < 2; ++k) {
      double col = 0, row = 0, pc = 0, pr = 0, dc = 0, dr = 0;
      ASSERT_TRUE(k == 0 ? detect_marker(img, col, row) : detect_flag_marker(img, col, row))
          << k << " at " << q0[1] << " " << q0[2] << " " << q0[3];
      ASSERT_TRUE(project(fit->camera, at[k], 1280, 960, pc, pr));
      ASSERT_TRUE(project_disc(fit->camera, at[k], radius[k], 1280, 960, dc, dr));
      worst_centre = std::max(worst_centre, std::hypot(col - pc, row - pr));
      worst_disc = std::max(worst_disc, std::hypot(col - dc, row - dr));
    }
  }
  // measured 0.51 px for the centre's projection, 0.31 px for the disc's centroid
  std::printf(
      "marker centroids vs the calibrated camera at 1280x960: centre %.3f px, disc %.3f px\n",
      worst_centre, worst_disc);
  EXPECT_LT(worst_centre, 0.7);
  EXPECT_LT(worst_disc, 0.4);
}

}  // namespace
}  // namespace scaratwin
