// scaratwin fk / ik: the kinematics at the command line. Edges speak metres and degrees.
#include <charconv>
#include <cmath>
#include <cstdio>
#include <vector>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "commands.hpp"
#include "scaratwin/config/robot_config.hpp"
#include "scaratwin/core/units.hpp"
#include "scaratwin/kinematics/kinematics.hpp"

namespace scaratwin::cli {

void add_common_options(CLI::App& cmd, CommonOptions& common, bool with_json) {
  cmd.add_option("--config", common.config_path,
                 "robot description (TOML); default: $SCARATWIN_CONFIG or config/scara.toml");
  if (with_json) cmd.add_flag("--json", common.json, "print one JSON object per result");
}

std::optional<RobotModel> load_model(const CommonOptions& common) {
  auto model = load_robot_config_or_default(common.config_path);
  if (!model) {
    std::fprintf(stderr, "scaratwin: %s\n", model.error().message.c_str());
    return std::nullopt;
  }
  return *model;
}

std::optional<std::filesystem::path> create_out_dir(const std::string& dir, const char* command) {
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec) {
    std::fprintf(stderr, "scaratwin %s: cannot create --out '%s': %s\n", command, dir.c_str(),
                 ec.message().c_str());
    return std::nullopt;
  }
  return std::filesystem::absolute(dir);
}

std::optional<JointVector> joints_from_edge(const std::vector<double>& v, const char* what) {
  if (v.size() != 4) {
    std::fprintf(stderr, "scaratwin: %s needs 4 values D1_M Q2_DEG Q3_DEG Q4_DEG, got %zu\n", what,
                 v.size());
    return std::nullopt;
  }
  static constexpr const char* kNames[4] = {"D1_M", "Q2_DEG", "Q3_DEG", "Q4_DEG"};
  for (std::size_t i = 0; i < 4; ++i) {
    if (!std::isfinite(v[i])) {
      std::fprintf(stderr, "scaratwin: %s: %s = %g: must be a finite number\n", what, kNames[i],
                   v[i]);
      return std::nullopt;
    }
  }
  return JointVector{v[0], deg_to_rad(v[1]), deg_to_rad(v[2]), deg_to_rad(v[3])};
}

namespace {

nlohmann::json joints_json(const JointVector& q) {
  return {{"d1_m", q[0]},
          {"q2_deg", rad_to_deg(q[1])},
          {"q3_deg", rad_to_deg(q[2])},
          {"q4_deg", rad_to_deg(q[3])}};
}

nlohmann::json pose_json(const ToolPose& p) {
  return {{"x_m", p.x_m}, {"y_m", p.y_m}, {"z_m", p.z_m}, {"yaw_deg", rad_to_deg(p.yaw_rad)}};
}

struct FkArgs {
  std::vector<double> joints;
  bool no_limits = false;
};

struct IkArgs {
  std::vector<double> pose;
  std::vector<double> seed;
  bool all = false;
};

int run_fk(const CommonOptions& common, const FkArgs& a) {
  auto model = load_model(common);
  if (!model) return kExitUsage;
  auto q = joints_from_edge(a.joints, "fk");
  if (!q) return kExitUsage;
  if (int j = first_joint_outside_limits(*model, *q); j >= 0 && !a.no_limits) {
    const double scale = j == 0 ? 1.0 : kDegPerRad;
    std::fprintf(stderr,
                 "scaratwin fk: %s = %g %s is outside its limits [%g, %g] (use --no-limits to "
                 "compute anyway)\n",
                 joint_name(j), (*q)[j] * scale, j == 0 ? "m" : "deg", model->limits[j].min * scale,
                 model->limits[j].max * scale);
    return kExitFailure;
  }
  const ToolPose p = forward(*model, *q);
  if (common.json) {
    std::puts(pose_json(p).dump().c_str());
  } else {
    fmt::print("x = {:.6f} m  y = {:.6f} m  z = {:.6f} m  yaw = {:.4f} deg\n", p.x_m, p.y_m, p.z_m,
               rad_to_deg(p.yaw_rad));
  }
  return kExitOk;
}

int run_ik(const CommonOptions& common, const IkArgs& a) {
  auto model = load_model(common);
  if (!model) return kExitUsage;
  static constexpr const char* kNames[4] = {"X_M", "Y_M", "Z_M", "YAW_DEG"};
  for (std::size_t i = 0; i < a.pose.size() && i < 4; ++i) {
    if (!std::isfinite(a.pose[i])) {
      std::fprintf(stderr, "scaratwin ik: %s = %g: must be a finite number\n", kNames[i],
                   a.pose[i]);
      return kExitUsage;
    }
  }
  JointVector seed = model->home;
  if (!a.seed.empty()) {
    auto s = joints_from_edge(a.seed, "--seed");
    if (!s) return kExitUsage;
    seed = *s;
  }
  const ToolPose target{a.pose[0], a.pose[1], a.pose[2], deg_to_rad(a.pose[3])};
  auto sol = inverse_all(*model, target, seed);
  if (!sol) {
    std::fprintf(stderr, "scaratwin ik: unreachable: %s\n", sol.error().message.c_str());
    return kExitFailure;
  }
  const int n = a.all ? sol->count : 1;
  for (int i = 0; i < n; ++i) {
    const JointVector& q = sol->solutions[i];
    if (common.json) {
      std::puts(joints_json(q).dump().c_str());
    } else {
      fmt::print("d1 = {:.6f} m  q2 = {:.4f} deg  q3 = {:.4f} deg  q4 = {:.4f} deg\n", q[0],
                 rad_to_deg(q[1]), rad_to_deg(q[2]), rad_to_deg(q[3]));
    }
  }
  return kExitOk;
}

}  // namespace

void add_kinematics_commands(CLI::App& app, CommonOptions& common, Runner& run) {
  auto fk_args = std::make_shared<FkArgs>();
  CLI::App* fk = app.add_subcommand("fk", "forward kinematics: tool pose of a joint state");
  fk->add_option("joints", fk_args->joints, "D1_M Q2_DEG Q3_DEG Q4_DEG")->expected(4)->required();
  fk->add_flag("--no-limits", fk_args->no_limits, "compute even outside the joint limits");
  add_common_options(*fk, common);
  fk->callback(
      [&common, &run, fk_args] { run = [&common, fk_args] { return run_fk(common, *fk_args); }; });

  auto ik_args = std::make_shared<IkArgs>();
  CLI::App* ik = app.add_subcommand(
      "ik", "inverse kinematics: joint state of a tool pose (nearest elbow solution)");
  ik->add_option("pose", ik_args->pose, "X_M Y_M Z_M YAW_DEG")->expected(4)->required();
  ik->add_option("--seed", ik_args->seed,
                 "current joints D1_M Q2_DEG Q3_DEG Q4_DEG (default: home); the nearest "
                 "solution is printed first")
      ->expected(4);
  ik->add_flag("--all", ik_args->all, "print every elbow solution within the limits");
  add_common_options(*ik, common);
  ik->callback(
      [&common, &run, ik_args] { run = [&common, ik_args] { return run_ik(common, *ik_args); }; });
}

}  // namespace scaratwin::cli
