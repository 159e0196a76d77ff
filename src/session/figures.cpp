#include "scaratwin/session/figures.hpp"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <map>

#include <nlohmann/json.hpp>

#include "scaratwin/core/units.hpp"

namespace scaratwin::session {

// The sorting succeeded: on the physical table when it can be seen (the emulated robot's
// truth), else in the virtual scene mirroring the robot.
bool physical_ok(const DemoOutcome& o, std::size_t cubes) {
  const int n = o.physical_in_trays >= 0 ? o.physical_in_trays : o.in_trays_replay;
  return n == static_cast<int>(cubes);
}

// Virtual -> physical tool along the motions of `run` between two monotonic times: the
// robot's reports (at its own clock) and the truth (at the same, emulated, clock).
ToolErrorStats virtual_vs_truth(TwinDb& db, const RobotModel& model, std::int64_t run,
                                const TruthRecorder& truth, std::uint64_t from_us,
                                std::uint64_t to_us, std::vector<double>* distances) {
  auto phys = db.samples(run, SampleSource::kPhysical);
  auto lat = db.latencies(run);
  if (!phys || !lat) return {};
  std::map<std::int64_t, std::int64_t> device_us;  // seq -> device clock
  for (const LatencyRecord& l : *lat) device_us[l.seq] = l.device_t_us;
  std::vector<TimedJoints> reports;
  for (const JointRecord& r : *phys) {
    auto it = device_us.find(r.seq);
    if (it != device_us.end()) reports.push_back({static_cast<double>(it->second) / 1e6, r.q});
  }
  std::sort(reports.begin(), reports.end(),
            [](const TimedJoints& x, const TimedJoints& y) { return x.t_s < y.t_s; });
  std::vector<ToolTruth> tt;
  // the reports' times are the firmware's micros(), which starts over at every reset of the
  // board (each open of a Uno's port): the truth's board clock is the same clock
  for (const TruthSample& t : truth.between(from_us, to_us)) {
    if (t.as_built)
      tt.push_back({static_cast<double>(t.board_us) / 1e6, {t.tool[0], t.tool[1], t.tool[2]}});
  }
  const ToolErrorStats st = tool_error_vs_truth(model, reports, tt, 0.05, distances);
  return st;
}

// Writes every figure of the session to results.json (keys: docs/results.md).
Status write_results(const std::filesystem::path& path, const std::string& plant,
                     const DemoOutcome& o) {
  using nlohmann::json;
  json j;
  j["plant"] = plant;
  j["control_error_target_physical_mm"] = o.control_error_mm;
  if (o.calibration) {
    const CalibrationFigures& c = *o.calibration;
    auto stats = [](const ToolErrorStats& e) {
      return json{
          {"mean", m_to_mm(e.mean_m)}, {"p95", m_to_mm(e.p95_m)}, {"max", m_to_mm(e.max_m)}};
    };
    json params = json::object();
    for (const CalibrationParameter& p : c.parameters) {
      params[p.key] = json{{"identified", p.identified},
                           {"std_error", p.std_error},
                           {"true", std::isnan(p.truth) ? json(nullptr) : json(p.truth)},
                           {"drawn", std::isnan(p.drawn) ? json(nullptr) : json(p.drawn)}};
    }
    j["calibration"] = json{
        {"before_mm", stats(c.before)}, {"after_mm", stats(c.after)}, {"test_poses", c.test_poses},
        {"fit_poses", c.fit_poses},     {"robot_s", c.robot_s},       {"fit_s", c.fit_s},
        {"pixel_rms", c.pixel_rms},     {"overlay", c.overlay},       {"parameters", params}};
  }
  j["virtual_vs_physical_tool_mm"] = o.virt_phys_along.count == 0
                                         ? json(nullptr)
                                         : json{{"mean", m_to_mm(o.virt_phys_along.mean_m)},
                                                {"p95", m_to_mm(o.virt_phys_along.p95_m)},
                                                {"max", m_to_mm(o.virt_phys_along.max_m)},
                                                {"samples", o.virt_phys_along.count}};
  j["physical_cubes_in_trays"] =
      o.physical_in_trays >= 0 ? json(o.physical_in_trays) : json(nullptr);
  j["virtual_cubes_in_trays"] = o.in_trays_replay;
  j["prediction_cubes_in_trays"] = o.in_trays_prediction;
  j["steps_lost"] = o.steps_lost_truth ? json{{"z", (*o.steps_lost_truth)[0]},
                                              {"j2", (*o.steps_lost_truth)[1]},
                                              {"j3", (*o.steps_lost_truth)[2]}}
                                       : json(nullptr);
  j["steps_lost_homing"] = o.steps_lost_homing ? json{{"z", (*o.steps_lost_homing)[0]},
                                                      {"j2", (*o.steps_lost_homing)[1]},
                                                      {"j3", (*o.steps_lost_homing)[2]}}
                                               : json(nullptr);
  j["mirror_latency_ms"] = {{"mean", o.latency.device_to_sim_ms.mean},
                            {"p50", o.latency.device_to_sim_ms.p50},
                            {"p99", o.latency.device_to_sim_ms.p99}};
  j["mirror_lost_frames"] = o.lost_frames;
  j["replay_vs_prediction_mm"] =
      std::isnan(o.replay_max_mm)
          ? json(nullptr)
          : json{{"rms", o.replay_rms_mm}, {"max", o.replay_max_mm}};
  std::ofstream f(path);
  f << j.dump(2) << "\n";
  if (!f) return Error{AppError::kWriteFailed, "cannot write " + path.string()};
  return Ok{};
}

}  // namespace scaratwin::session
