// scaratwin plan: joint trajectories (quintic, trapezoid, via points), Cartesian lines and
// pick-and-place, printed as a summary, CSV or JSON.
#include <cmath>
#include <cstdio>
#include <sstream>
#include <vector>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "commands.hpp"
#include "scaratwin/core/units.hpp"
#include "scaratwin/kinematics/motor.hpp"
#include "scaratwin/trajectory/trajectory.hpp"

namespace scaratwin::cli {
namespace {

struct PlanArgs {
  std::vector<double> from, to, line, pick, place;
  std::vector<std::string> via;
  std::string profile = "quintic";
  int samples = 60;
  double duration_s = 0.0;
  double dt_s = 0.01;
  double speed_scale = 1.0;
  bool csv = false;
};

std::optional<ToolPose> pose_from_edge(const std::vector<double>& v, const char* what) {
  if (v.size() != 4) {
    std::fprintf(stderr, "scaratwin plan: %s needs 4 values X_M Y_M Z_M YAW_DEG, got %zu\n", what,
                 v.size());
    return std::nullopt;
  }
  static constexpr const char* kNames[4] = {"X_M", "Y_M", "Z_M", "YAW_DEG"};
  for (std::size_t i = 0; i < 4; ++i) {
    if (!std::isfinite(v[i])) {
      std::fprintf(stderr, "scaratwin plan: %s: %s = %g: must be a finite number\n", what,
                   kNames[i], v[i]);
      return std::nullopt;
    }
  }
  return ToolPose{v[0], v[1], v[2], deg_to_rad(v[3])};
}

void print_csv(const JointTrajectory& t) {
  std::puts(
      "t_s,d1_m,q2_deg,q3_deg,q4_deg,v_d1_mps,v_q2_dps,v_q3_dps,v_q4_dps,a_d1_mps2,a_q2_dps2,"
      "a_q3_dps2,a_q4_dps2");
  for (const JointSample& s : t.samples) {
    std::string line = fmt::format("{:.17g}", s.t_s);
    for (const JointVector* v : {&s.q, &s.qd, &s.qdd}) {
      line += fmt::format(",{:.17g}", (*v)[0]);
      for (int j = 1; j < kNumJoints; ++j) line += fmt::format(",{:.17g}", rad_to_deg((*v)[j]));
    }
    std::puts(line.c_str());
  }
}

void print_json(const JointTrajectory& t) {
  nlohmann::json out;
  out["duration_s"] = t.duration_s();
  auto& samples = out["samples"] = nlohmann::json::array();
  for (const JointSample& s : t.samples) {
    samples.push_back({{"t_s", s.t_s},
                       {"d1_m", s.q[0]},
                       {"q2_deg", rad_to_deg(s.q[1])},
                       {"q3_deg", rad_to_deg(s.q[2])},
                       {"q4_deg", rad_to_deg(s.q[3])}});
  }
  auto& events = out["events"] = nlohmann::json::array();
  for (const GripperEvent& e : t.events) {
    events.push_back(
        {{"t_s", e.t_s}, {"action", e.action == GripperAction::kGrip ? "grip" : "release"}});
  }
  std::puts(out.dump().c_str());
}

void print_summary(const RobotModel& model, const JointTrajectory& t) {
  std::array<double, 4> peak_v{}, peak_a{};
  for (const JointSample& s : t.samples) {
    const auto v = motor_rates(model, s.qd), a = motor_rates(model, s.qdd);
    for (int i = 0; i < 4; ++i) {
      peak_v[i] = std::max(peak_v[i], std::abs(v[i]));
      peak_a[i] = std::max(peak_a[i], std::abs(a[i]));
    }
  }
  const JointVector& a = t.samples.front().q;
  const JointVector& b = t.samples.back().q;
  fmt::print("{} samples over {:.3f} s, {} gripper events\n", t.samples.size(), t.duration_s(),
             t.events.size());
  fmt::print("start  d1 {:.4f} m  q2 {:.2f}  q3 {:.2f}  q4 {:.2f} deg\n", a[0], rad_to_deg(a[1]),
             rad_to_deg(a[2]), rad_to_deg(a[3]));
  fmt::print("end    d1 {:.4f} m  q2 {:.2f}  q3 {:.2f}  q4 {:.2f} deg\n", b[0], rad_to_deg(b[1]),
             rad_to_deg(b[2]), rad_to_deg(b[3]));
  const StepperAxis* axes[] = {&model.motors.z, &model.motors.j2, &model.motors.j3};
  static constexpr const char* kMotor[] = {"Z", "J2", "J3"};
  fmt::print("motor  peak speed (limit)          peak accel (limit)\n");
  for (int i = 0; i < 3; ++i) {
    fmt::print("{:<5}  {:8.1f} ({:6.0f}) steps/s   {:8.1f} ({:6.0f}) steps/s^2\n", kMotor[i],
               peak_v[i], axes[i]->max_speed_steps_s, peak_a[i], axes[i]->max_accel_steps_s2);
  }
  fmt::print("wrist  {:8.1f} ({:6.0f}) deg/s\n", peak_v[3], model.motors.wrist.max_speed_deg_s);
  for (const GripperEvent& e : t.events) {
    fmt::print("{:7.3f} s  {}\n", e.t_s, e.action == GripperAction::kGrip ? "grip" : "release");
  }
}

int run_plan(const CommonOptions& common, const PlanArgs& a) {
  auto model = load_model(common);
  if (!model) return kExitUsage;
  JointVector from = model->home;
  if (!a.from.empty()) {
    auto q = joints_from_edge(a.from, "--from");
    if (!q) return kExitUsage;
    from = *q;
  }
  const int modes = !a.to.empty() + !a.line.empty() + !a.pick.empty() + !a.via.empty();
  if (modes != 1 || a.pick.empty() != a.place.empty()) {
    std::fprintf(stderr,
                 "scaratwin plan: give exactly one of --to, --line, --via or --pick with "
                 "--place (see --help)\n");
    return kExitUsage;
  }
  if (a.profile != "quintic" && a.profile != "trapezoid") {
    std::fprintf(stderr, "scaratwin plan: --profile '%s': expected quintic or trapezoid\n",
                 a.profile.c_str());
    return kExitUsage;
  }
  Result<JointTrajectory> traj = Error{};
  if (!a.to.empty()) {
    auto to = joints_from_edge(a.to, "--to");
    if (!to) return kExitUsage;
    traj = a.profile == "quintic"
               ? plan_quintic(*model, from, *to, {a.samples, a.duration_s})
               : plan_trapezoid(*model, from, *to, {a.dt_s, a.speed_scale, a.speed_scale});
  } else if (!a.via.empty()) {
    std::vector<JointVector> points{from};
    for (const std::string& v : a.via) {
      std::vector<double> vals;
      std::stringstream ss(v);
      std::string item;
      while (std::getline(ss, item, ',')) {
        try {
          vals.push_back(std::stod(item));
        } catch (...) {
          std::fprintf(stderr, "scaratwin plan: --via '%s': '%s' is not a number\n", v.c_str(),
                       item.c_str());
          return kExitUsage;
        }
      }
      auto q = joints_from_edge(vals, "--via");
      if (!q) return kExitUsage;
      points.push_back(*q);
    }
    ViaOptions o;
    o.profile = a.profile == "quintic" ? Profile::kQuintic : Profile::kTrapezoid;
    o.trapezoid = {a.dt_s, a.speed_scale, a.speed_scale};
    o.quintic_samples = a.samples;
    traj = plan_via_points(*model, points, o);
  } else if (!a.line.empty()) {
    auto goal = pose_from_edge(a.line, "--line");
    if (!goal) return kExitUsage;
    traj = plan_line(*model, from, *goal, {0.001, a.dt_s, a.speed_scale, a.speed_scale});
  } else {
    auto pick = pose_from_edge(a.pick, "--pick");
    auto place = pose_from_edge(a.place, "--place");
    if (!pick || !place) return kExitUsage;
    PickPlaceRequest r;
    r.pick = *pick;
    r.place = *place;
    r.approach_height_m = model->scene.approach_height_m;
    r.speed_scale = r.accel_scale = a.speed_scale;
    r.dt_s = a.dt_s;
    traj = plan_pick_place(*model, from, r);
  }
  if (!traj) {
    std::fprintf(stderr, "scaratwin plan: %s\n", traj.error().message.c_str());
    return kExitFailure;
  }
  if (a.csv) {
    print_csv(*traj);
  } else if (common.json) {
    print_json(*traj);
  } else {
    print_summary(*model, *traj);
  }
  return kExitOk;
}

}  // namespace

void add_plan_command(CLI::App& app, CommonOptions& common, Runner& run) {
  auto a = std::make_shared<PlanArgs>();
  CLI::App* cmd = app.add_subcommand(
      "plan", "plan a trajectory: joint move (--to), via points, Cartesian line or pick-and-place");
  cmd->add_option("--from", a->from, "start joints D1_M Q2_DEG Q3_DEG Q4_DEG (default: home)")
      ->expected(4);
  cmd->add_option("--to", a->to, "goal joints D1_M Q2_DEG Q3_DEG Q4_DEG")->expected(4);
  cmd->add_option("--via", a->via, "via point 'D1_M,Q2_DEG,Q3_DEG,Q4_DEG' (repeat; in order)");
  cmd->add_option("--line", a->line, "straight tool line to X_M Y_M Z_M YAW_DEG")->expected(4);
  cmd->add_option("--pick", a->pick, "pick pose X_M Y_M Z_M YAW_DEG (with --place)")->expected(4);
  cmd->add_option("--place", a->place, "place pose X_M Y_M Z_M YAW_DEG (with --pick)")->expected(4);
  cmd->add_option("--profile", a->profile, "joint profile: quintic (paper's jtraj) or trapezoid")
      ->capture_default_str();
  // bad numbers are bad input (exit 2, the value named), not a plan that failed (exit 1)
  cmd->add_option("--samples", a->samples, "samples of a quintic")
      ->capture_default_str()
      ->check(CLI::Range(2, 1000000));
  cmd->add_option("--duration", a->duration_s,
                  "duration of a quintic in s (0: shortest within the motor limits)")
      ->capture_default_str()
      ->check(CLI::NonNegativeNumber);
  cmd->add_option("--dt", a->dt_s, "sample spacing of trapezoids and lines, s")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  cmd->add_option("--speed-scale", a->speed_scale, "fraction of the motor limits to use (0, 1]")
      ->capture_default_str()
      ->check(CLI::PositiveNumber & CLI::Range(0.0, 1.0));
  cmd->add_flag("--csv", a->csv, "print every sample as CSV (SI lengths, degrees)");
  add_common_options(*cmd, common);
  cmd->callback([&common, &run, a] { run = [&common, a] { return run_plan(common, *a); }; });
}

}  // namespace scaratwin::cli
