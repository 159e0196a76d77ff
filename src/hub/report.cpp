#include "scaratwin/hub/report.hpp"

#include <cmath>
#include <ctime>
#include <fstream>
#include <map>

#include <fmt/format.h>

#include "scaratwin/core/units.hpp"
#include "scaratwin/hub/analysis.hpp"
#include "svg_plot.hpp"

namespace scaratwin {
namespace {

constexpr const char* kStyle = R"css(
body { font-family: sans-serif; margin: 24px auto; max-width: 1000px; color: #222; }
h1 { font-size: 22px; } h2 { font-size: 18px; border-bottom: 1px solid #ccc; margin-top: 32px; }
table { border-collapse: collapse; margin: 8px 0; } td, th { border: 1px solid #ccc;
padding: 4px 10px; text-align: right; } th { background: #f0f0f0; } td:first-child,
th:first-child { text-align: left; } .plots { display: flex; flex-wrap: wrap; gap: 8px; }
.ok { color: #1a7f37; font-weight: bold; } .failed { color: #c62828; font-weight: bold; }
.note { color: #666; font-size: 13px; }
)css";

constexpr const char* kJointNames[] = {"d1 (mm)", "q2 (deg)", "q3 (deg)", "q4 (deg)"};

double edge_value(int j, double v) { return j == 0 ? m_to_mm(v) : rad_to_deg(v); }

std::string status_span(const std::string& status) {
  return fmt::format("<span class='{}'>{}</span>", status == "ok" ? "ok" : "failed", status);
}

std::string joint_plots(const std::vector<JointRecord>& virt, const std::vector<JointRecord>& phys,
                        const std::vector<JointRecord>& planned) {
  std::string out = "<div class='plots'>\n";
  for (int j = 0; j < kNumJoints; ++j) {
    std::vector<svg::Series> series;
    const auto add = [&](const std::vector<JointRecord>& rec, const char* name, const char* color,
                         bool dashed) {
      if (rec.empty()) return;
      svg::Series s{name, color, {}, {}, dashed};
      for (const JointRecord& r : rec) {
        s.x.push_back(r.t_s);
        s.y.push_back(edge_value(j, r.q[static_cast<size_t>(j)]));
      }
      series.push_back(std::move(s));
    };
    add(planned, "planned", "#999999", true);
    add(phys, "physical", "#d9480f", false);
    add(virt, "virtual", "#1c7ed6", true);
    out += svg::line_chart(fmt::format("joint {}", kJointNames[j]), "time (s)", kJointNames[j],
                           series, 480, 230);
  }
  return out + "</div>\n";
}

std::string path_plots(const RobotModel& model, const std::vector<JointRecord>& virt,
                       const std::vector<JointRecord>& phys) {
  std::vector<svg::Series> top, side;
  const auto add = [&](const std::vector<JointRecord>& rec, const char* name, const char* color,
                       bool dashed) {
    if (rec.empty()) return;
    svg::Series t{name, color, {}, {}, dashed}, s{name, color, {}, {}, dashed};
    for (const JointRecord& r : rec) {
      const ToolPose p = forward(model, r.q);
      t.x.push_back(m_to_mm(p.x_m));
      t.y.push_back(m_to_mm(p.y_m));
      s.x.push_back(m_to_mm(p.x_m));
      s.y.push_back(m_to_mm(p.z_m));
    }
    top.push_back(std::move(t));
    side.push_back(std::move(s));
  };
  add(phys, "physical", "#d9480f", false);
  add(virt, "virtual", "#1c7ed6", true);
  return "<div class='plots'>\n" +
         svg::line_chart("tool path, top view", "x (mm)", "y (mm)", top, 480, 360, true) +
         svg::line_chart("tool path, side view", "x (mm)", "z (mm)", side, 480, 360, true) +
         "</div>\n";
}

std::string metrics_table(const std::vector<MetricRecord>& metrics) {
  if (metrics.empty()) return "";
  std::string out = "<table><tr><th>figure</th><th>value</th><th>unit</th></tr>\n";
  for (const MetricRecord& m : metrics) {
    if (m.name.starts_with(metric::kCalibParamPrefix)) continue;  // their own table
    out += fmt::format("<tr><td>{}</td><td>{:.4g}</td><td>{}</td></tr>\n", m.name, m.value, m.unit);
  }
  return out + "</table>\n";
}

// The identified parameters beside the truth (metric::kCalibParamPrefix), if calibrated.
std::string calibration_table(const std::map<std::string, std::vector<double>>& all) {
  const std::string prefix = metric::kCalibParamPrefix;
  std::string rows;
  for (const auto& [name, v] : all) {
    if (!name.starts_with(prefix) || name.ends_with(".se") || name.ends_with(".true")) continue;
    auto value_of = [&all](const std::string& n) {
      auto it = all.find(n);
      return it == all.end() || it->second.empty() ? std::nan("") : it->second.back();
    };
    const double se = value_of(name + ".se"), truth = value_of(name + ".true");
    const double off = std::abs(v.back() - truth) / se;
    rows +=
        fmt::format("<tr><td>{}</td><td>{:.4f}</td><td>{:.4f}</td><td>{}</td><td>{}</td></tr>\n",
                    name.substr(prefix.size()), v.back(), se,
                    std::isnan(truth) ? "not measured" : fmt::format("{:.4f}", truth),
                    std::isnan(off) ? "" : fmt::format("{:.1f}", off));
  }
  if (rows.empty()) return "";
  return "<h2>Calibration: the robot as identified and as built</h2>\n<table><tr><th>parameter "
         "(unit in its name)</th><th>identified</th><th>std error</th><th>true (emulator)</th>"
         "<th>|off| / std error</th></tr>\n" +
         rows +
         "</table>\n<p class='note'>Deviations from the base description; the camera as the "
         "change from the description's. True: the joint map as the emulator's truth measured "
         "it at the routine's poses, the links as the build drew them (docs/calibration.md).</p>"
         "\n";
}

struct PaperRow {
  const char* metric;
  const char* what;
  const char* paper;
  const char* unit;
};

// The paper's figures (Zhang et al. 2024, section 6) beside the metrics we record.
constexpr PaperRow kPaperRows[] = {
    {metric::kLatencyMeanMs, "mirror latency, robot sample to virtual robot, mean",
     "74.4 / 72.5 / 76.4 (three runs)", "ms"},
    {metric::kLatencyP99Ms, "mirror latency, 99th percentile", "not reported (spikes shown)", "ms"},
    {metric::kLostFrames, "mirror frames lost", "\"no data loss\" (not counted)", "frames"},
    {metric::kToolErrTargetPhysMm, "control: tool error, target vs physical end pose",
     "2.01 / 3.83 / 2.94", "mm"},
    {metric::kToolErrVirtPhysMm, "control: tool error, virtual vs physical", "not reported", "mm"},
    {metric::kReplayToolMaxMm, "prediction vs physical replay, tool deviation max",
     "\"coincided\" (plots only)", "mm"},
    {metric::kCubesInTray, "colour sorting: cubes in their trays", "3 of 3 (three runs)", "cubes"},
    // against the physical truth of the emulated robot as built (absent with a real board)
    {metric::kControlErrTrueMm, "control: tool error, target vs the true tool (robot as built)",
     "2.01 / 3.83 / 2.94", "mm"},
    {metric::kVirtTrueMeanMm, "virtual vs the true tool along every motion, mean", "not reported",
     "mm"},
    {metric::kVirtTrueMaxMm, "virtual vs the true tool along every motion, max", "not reported",
     "mm"},
    {metric::kPhysicalCubesInTray, "colour sorting: physical cubes in their trays (the truth)",
     "3 of 3 (three runs)", "cubes"},
    {metric::kLostStepsTrue, "steps lost by the motors (the truth)", "not reported", "steps"},
    {metric::kCalibBeforeMeanMm, "virtual vs the true tool at test poses, before calibration, mean",
     "2-4 (virtual vs physical, uncalibrated)", "mm"},
    {metric::kCalibBeforeMaxMm, "virtual vs the true tool at test poses, before calibration, max",
     "not reported", "mm"},
    {metric::kCalibAfterMeanMm, "virtual vs the true tool at test poses, after calibration, mean",
     "no calibration", "mm"},
    {metric::kCalibAfterMaxMm, "virtual vs the true tool at test poses, after calibration, max",
     "no calibration", "mm"},
};

}  // namespace

Status write_report(TwinDb& db, const RobotModel& model, int64_t run_id,
                    const std::filesystem::path& html) {
  auto top = db.run(run_id);
  if (!top) return top.error();
  auto kids = db.children(run_id);
  if (!kids) return kids.error();
  std::vector<RunInfo> runs{*top};
  runs.insert(runs.end(), kids->begin(), kids->end());

  // every metric of the session; a name recorded several times (the three control targets)
  // shows every value in order.
  std::map<std::string, std::vector<double>> all;
  for (const RunInfo& r : runs) {
    auto m = db.metrics(r.id);
    if (!m) return m.error();
    for (const MetricRecord& x : *m) all[x.name].push_back(x.value);
  }

  std::string body;
  const std::time_t started = static_cast<std::time_t>(top->started_unix_s);
  char when[64];
  std::strftime(when, sizeof when, "%Y-%m-%d %H:%M:%S UTC", std::gmtime(&started));
  body +=
      fmt::format("<h1>scaratwin report: run {} ({}, {})</h1>\n", top->id, top->kind, top->label);
  body += fmt::format("<p>Started {}, {:.1f} s, status {}. Robot: {}. Database: {}</p>\n", when,
                      top->duration_s, status_span(top->status), model.name, db.path().string());

  body +=
      "<h2>Our figures beside the paper's</h2>\n<table><tr><th>figure</th><th>scaratwin</th>"
      "<th>paper</th><th>unit</th></tr>\n";
  for (const PaperRow& row : kPaperRows) {
    auto it = all.find(row.metric);
    std::string ours = "not measured";
    if (it != all.end()) {
      ours.clear();
      for (double v : it->second) ours += (ours.empty() ? "" : " / ") + fmt::format("{:.3g}", v);
    }
    body += fmt::format("<tr><td>{}</td><td>{}</td><td>{}</td><td>{}</td></tr>\n", row.what, ours,
                        row.paper, row.unit);
  }
  body +=
      "</table>\n<p class='note'>Paper: Zhang, Guo, Grigorev, Kholodilin, Sensors 2024, 24, "
      "7183 (Unity3D + MATLAB + Arduino, AMD 5600U). Our latency is measured per frame from "
      "sequence numbers and timestamps; the emulator's ground truth comes from the "
      "firmware's STEP/DIR pins.</p>\n";

  body += calibration_table(all);

  for (const RunInfo& r : runs) {
    auto virt = db.samples(r.id, SampleSource::kVirtual);
    auto phys = db.samples(r.id, SampleSource::kPhysical);
    auto planned = db.samples(r.id, SampleSource::kPlanned);
    auto lat = db.latencies(r.id);
    auto metrics = db.metrics(r.id);
    auto events = db.events(r.id);
    if (!virt || !phys || !planned || !lat || !metrics || !events) {
      return Error{DbError::kNoRun, fmt::format("report: cannot read run {}", r.id)};
    }
    if (r.id != top->id || !virt->empty() || !phys->empty()) {
      body += fmt::format("<h2>Run {}: {} ({}), {:.1f} s, {}</h2>\n", r.id, r.kind, r.label,
                          r.duration_s, status_span(r.status));
    }
    body += metrics_table(*metrics);
    if (!virt->empty() || !phys->empty() || !planned->empty()) {
      body += joint_plots(*virt, *phys, *planned);
      body += path_plots(model, *virt, *phys);
    }
    if (!virt->empty() && !phys->empty()) {
      const Deviation d = compare_runs(model, *phys, *virt);
      std::vector<double> mm;
      for (double e : d.tool_err_m) mm.push_back(m_to_mm(e));
      body += "<div class='plots'>\n" +
              svg::line_chart("tool deviation, virtual vs physical", "time (s)", "mm",
                              {{"|virtual - physical|", "#2b8a3e", d.t_s, mm, false}}, 480, 230);
      if (!lat->empty()) {
        body += svg::histogram(
            "mirror latency, hub receive to simulator applied", "ms",
            [&] {
              std::vector<double> v;
              for (const LatencyRecord& x : *lat) {
                v.push_back(static_cast<double>(x.sim_apply_us - x.hub_rx_us) / 1000.0);
              }
              return v;
            }(),
            40, 480, 230);
      }
      body += "</div>\n";
    }
    if (r.ref != 0) {
      auto pred = db.samples(r.ref, SampleSource::kVirtual);
      if (pred && !pred->empty() && !phys->empty()) {
        const Deviation d = compare_runs_by_progress(model, as_plan(*pred), *pred, *phys);
        std::vector<double> mm;
        for (double e : d.tool_err_m) mm.push_back(m_to_mm(e));
        body += fmt::format(
            "<p>Compared with the prediction (run {}) at equal progress along its path (the "
            "two clocks differ; where the robots went counts): tool deviation max {:.3f} "
            "mm, RMS {:.3f} mm, final {:.3f} mm.</p>\n",
            r.ref, m_to_mm(d.tool_max_m), m_to_mm(d.tool_rms_m), m_to_mm(d.tool_final_m));
        body += "<div class='plots'>\n" +
                svg::line_chart(
                    "prediction vs physical replay", "prediction time (s)", "tool deviation (mm)",
                    {{"|prediction - replay|", "#862e9c", d.t_s, mm, false}}, 480, 230) +
                "</div>\n";
      }
    }
    if (!events->empty()) {
      body += "<details><summary>events</summary><table><tr><th>t (s)</th><th>event</th></tr>";
      for (const auto& [t, e] : *events) {
        body += fmt::format("<tr><td>{:.3f}</td><td>{}</td></tr>", t, e);
      }
      body += "</table></details>\n";
    }
  }

  std::error_code ec;
  if (html.has_parent_path()) std::filesystem::create_directories(html.parent_path(), ec);
  const std::filesystem::path tmp = html.string() + ".tmp";
  {
    std::ofstream out(tmp);
    out << "<!doctype html>\n<html><head><meta charset='utf-8'><title>scaratwin report " << top->id
        << "</title><style>" << kStyle << "</style></head><body>\n"
        << body << "</body></html>\n";
    if (!out)
      return Error{DbError::kWriteFailed, fmt::format("cannot write report '{}'", tmp.string())};
  }
  std::filesystem::rename(tmp, html, ec);
  if (ec)
    return Error{DbError::kWriteFailed,
                 fmt::format("cannot write report '{}': {}", html.string(), ec.message())};
  return Ok{};
}

}  // namespace scaratwin
