// Calibration end to end, as a user runs it: `scaratwin calibrate` against the emulated robot
// as built from three seeds (its firmware in the AVR emulator, its own MuJoCo world, camera and
// scripted operator). The overlay it writes must load as a description, and every robot
// parameter it identified must lie within 3 standard errors of the robot as built: its links
// as the emulator drew them, its joint map as the emulator's truth measured it.
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <toml++/toml.h>

#include "../parameter_bounds.hpp"
#include "scaratwin/config/robot_config.hpp"
#include "scaratwin/hub/process.hpp"
#include "scaratwin/kinematics/physical.hpp"

namespace scaratwin {
namespace {

namespace fs = std::filesystem;
using namespace std::chrono_literals;

class CalibrateSeed : public ::testing::TestWithParam<int> {};

// The joint map the robot as built really has, from the emulator's truth logged beside each
// measurement (calibration-truth.csv): where each joint rests against the firmware's counts.
// Written out here from the joint map's definition (docs/calibration.md), not with the
// command's own code: Z and the wrist by a straight line, each belt joint from the mean of its
// rests after moving up and after moving down. In the overlay's units (mm, deg, percent).
std::map<std::string, double> measured_joint_map(const fs::path& csv, const RobotModel& base) {
  std::ifstream in(csv);
  std::string line;
  std::getline(in, line);  // header
  constexpr double kDeg = 180.0 / 3.14159265358979323846;
  struct Line {
    double sx = 0, sy = 0, sxx = 0, sxy = 0, n = 0;
    void add(double x, double y) { sx += x, sy += y, sxx += x * x, sxy += x * y, n += 1; }
    double slope() const { return (n * sxy - sx * sy) / (n * sxx - sx * sx); }
    double at0() const { return (sy - slope() * sx) / n; }
  } z, wrist;
  double up[2] = {0, 0}, down[2] = {0, 0};
  int n_up[2] = {0, 0}, n_down[2] = {0, 0};
  const double sw = base.endstops.closes_at[0];
  while (std::getline(in, line)) {
    std::stringstream ss(line);
    std::string kind, cell;
    std::getline(ss, kind, ',');
    std::vector<double> v;
    while (std::getline(ss, cell, ',')) v.push_back(std::stod(cell));
    if (v.size() < 10) continue;
    // q_fw0..3, dir1, dir2, true0..3
    z.add(v[0] - sw, v[6] - v[0]);
    wrist.add(v[3], v[9] - v[3]);
    for (int j = 0; j < 2; ++j) {
      const double off = v[7 + j] - v[1 + j];
      if (v[4 + j] > 0) up[j] += off, ++n_up[j];
      if (v[4 + j] < 0) down[j] += off, ++n_down[j];
    }
  }
  std::map<std::string, double> out;
  out["z_offset_mm"] = z.at0() * 1e3;
  out["z_scale_percent"] = z.slope() * 100.0;
  out["wrist_offset_deg"] = wrist.at0() * kDeg;
  out["wrist_gain_percent"] = wrist.slope() * 100.0;
  for (int j = 0; j < 2; ++j) {
    if (n_up[j] == 0 || n_down[j] == 0) continue;
    const double u = up[j] / n_up[j], d = down[j] / n_down[j], band = d - u;
    const double hd = base.endstops.homing_dir[1 + j];
    // the joint map: rest = counts + zero + band/2 (hd - dir)
    out[j == 0 ? "j2_backlash_deg" : "j3_backlash_deg"] = band * kDeg;
    out[j == 0 ? "j2_zero_deg" : "j3_zero_deg"] = (u - 0.5 * band * (hd - 1.0)) * kDeg;
  }
  return out;
}

// One build end to end: the routine must identify it. The oracles: the link lengths the
// emulator drew for this seed (draw_as_built of the same seed), and the joint map the truth
// measured at the routine's poses (measured_joint_map). Each within 3 standard errors.
void calibrates_build(int seed) {
  const fs::path dir =
      fs::temp_directory_path() / fmt::format("scaratwin-calibrate-{}-{}", seed, getpid());
  fs::remove_all(dir);
  fs::create_directories(dir);
  const fs::path overlay = dir / "scara.calibrated.toml";
  auto cal = ChildProcess::start(
      fs::path(SCARATWIN_BIN_DIR) / "scaratwin",
      {"calibrate", "--config", SCARATWIN_CONFIG_FILE, "--as-built-seed", std::to_string(seed),
       "--output", overlay.string(), "--out", dir.string()},
      dir / "calibrate.log");
  ASSERT_TRUE(cal) << cal.error().message;
  const int status = (*cal)->wait_exit(1500s);
  ASSERT_EQ(status, 0) << (*cal)->output_tail(200);

  // the overlay loads as the calibrated description
  auto model = load_robot_config(overlay);
  ASSERT_TRUE(model) << model.error().message;
  EXPECT_TRUE(model->webcam.valid);

  RobotModel base = *load_robot_config(SCARATWIN_CONFIG_FILE);
  base.physical.as_built.seed = static_cast<std::uint64_t>(seed);
  const AsBuilt built = draw_as_built(base.physical.as_built);
  auto drawn = [&](AsBuiltParam p) {
    return built[p] / as_built_keys()[static_cast<int>(p)].to_si;  // mm
  };
  std::map<std::string, double> truth = measured_joint_map(dir / "calibration-truth.csv", base);
  ASSERT_EQ(truth.size(), 8u) << "the truth log lacks a joint's two sides";
  truth["a2_mm"] = drawn(AsBuiltParam::kA2);
  truth["a3_mm"] = drawn(AsBuiltParam::kA3);
  truth["jaw_offset_mm"] = drawn(AsBuiltParam::kJawOffset);

  const toml::table t = toml::parse_file(overlay.string());
  const toml::table* id = t["calibration"]["identified"].as_table();
  ASSERT_NE(id, nullptr);
  for (const auto& [key, true_value] : truth) {
    const toml::array* v = (*id)[key].as_array();
    ASSERT_NE(v, nullptr) << key;
    const double identified = v->get(0)->value<double>().value_or(NAN);
    const double se = v->get(1)->value<double>().value_or(NAN);
    EXPECT_LE(std::abs(identified - true_value), 3.0 * se)
        << "seed " << seed << ": " << key << " identified " << identified << " +- " << se
        << ", true " << true_value;
    EXPECT_LE(std::abs(identified - true_value), test::absolute_bound(key))
        << "seed " << seed << ": " << key << " identified " << identified << ", true "
        << true_value;
  }
  // under 3 minutes of the robot's own (emulated) time
  const std::string out = (*cal)->output_tail(400);
  const auto at = out.find(" s of robot time, ");
  ASSERT_NE(at, std::string::npos) << out;
  const auto from = out.rfind("routine ", at);
  ASSERT_NE(from, std::string::npos) << out;
  const double robot_s = std::stod(out.substr(from + 8, at - from - 8));
  EXPECT_LT(robot_s, 180.0) << out;
  fs::remove_all(dir);
}

// Three builds: by hand (label `long`, docs/calibration.md), about 3-5 minutes each; CI's
// short form is the demo's calibration of the description's own build (test_demo).
TEST_P(CalibrateSeed, IdentifiesTheBuildWithinThreeStandardErrors) { calibrates_build(GetParam()); }

INSTANTIATE_TEST_SUITE_P(ThreeBuilds, CalibrateSeed, ::testing::Values(3, 11, 42));

// A robot whose pattern cannot be seen (the operator never lays it down): refused with the
// reason, exit 1, and no overlay written.
TEST(Calibrate, RefusesWithoutTheWebcamAndWritesNothing) {
  const fs::path dir =
      fs::temp_directory_path() / fmt::format("scaratwin-calibrate-x-{}", getpid());
  fs::remove_all(dir);
  fs::create_directories(dir);
  const fs::path overlay = dir / "out.toml";
  // the ideal plant has no webcam
  auto cal = ChildProcess::start(fs::path(SCARATWIN_BIN_DIR) / "scaratwin",
                                 {"calibrate", "--config", SCARATWIN_CONFIG_FILE, "--serial",
                                  "/dev/null", "--output", overlay.string(), "--out", dir.string()},
                                 dir / "calibrate.log");
  ASSERT_TRUE(cal);
  EXPECT_EQ((*cal)->wait_exit(60s), 2);
  EXPECT_NE((*cal)->output_tail(200).find("a real robot needs its webcam: --camera HOST:PORT"),
            std::string::npos)
      << (*cal)->output_tail(200);
  EXPECT_FALSE(fs::exists(overlay));
  fs::remove_all(dir);
}

}  // namespace
}  // namespace scaratwin
