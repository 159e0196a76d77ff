#include "scaratwin/hub/analysis.hpp"

#include <algorithm>
#include <cmath>

namespace scaratwin {

Stats summarize(std::vector<double> v) {
  Stats s;
  s.count = v.size();
  if (v.empty()) return s;
  std::sort(v.begin(), v.end());
  double sum = 0.0;
  for (double x : v) sum += x;
  s.mean = sum / static_cast<double>(v.size());
  const auto pct = [&](double p) {
    const double idx = p * static_cast<double>(v.size() - 1);
    const size_t lo = static_cast<size_t>(idx);
    const size_t hi = std::min(lo + 1, v.size() - 1);
    return v[lo] + (idx - static_cast<double>(lo)) * (v[hi] - v[lo]);
  };
  s.p50 = pct(0.50);
  s.p95 = pct(0.95);
  s.p99 = pct(0.99);
  s.max = v.back();
  return s;
}

LatencyFigures latency_figures(const std::vector<LatencyRecord>& frames, double wire_s) {
  LatencyFigures f;
  if (frames.empty()) return f;
  std::vector<double> hub;
  // device timestamps are u32 microseconds: unwrap them first.
  std::vector<int64_t> dev(frames.size());
  int64_t wraps = 0;
  for (size_t i = 0; i < frames.size(); ++i) {
    if (i > 0 && frames[i].device_t_us + wraps < dev[i - 1] - (int64_t{1} << 31)) {
      wraps += int64_t{1} << 32;
    }
    dev[i] = frames[i].device_t_us + wraps;
  }
  for (size_t i = 0; i < frames.size(); ++i) {
    hub.push_back(static_cast<double>(frames[i].sim_apply_us - frames[i].hub_rx_us) / 1000.0);
    if (i > 0) {
      const int64_t gap = (frames[i].seq - frames[i - 1].seq - 1 + 65536) % 65536;
      f.lost_frames += gap;
    }
  }
  // The device clock is not the host's and drifts from it (an emulator that falls behind real
  // time, a crystal's tolerance), so the offset is the smallest receive-minus-sample
  // difference within a window of frames around each one.
  constexpr size_t kWindow = 50;
  for (size_t i = 0; i < frames.size(); ++i) {
    int64_t offset = INT64_MAX;
    const size_t lo = i > kWindow ? i - kWindow : 0;
    const size_t hi = std::min(frames.size(), i + kWindow + 1);
    for (size_t j = lo; j < hi; ++j) offset = std::min(offset, frames[j].hub_rx_us - dev[j]);
    const double sample_host_us =
        static_cast<double>(dev[i] + offset) - wire_s * 1e6;  // earliest possible
    f.device_to_sim_series_ms.push_back(
        (static_cast<double>(frames[i].sim_apply_us) - sample_host_us) / 1000.0);
  }
  f.hub_to_sim_ms = summarize(hub);
  f.device_to_sim_ms = summarize(f.device_to_sim_series_ms);
  return f;
}

JointVector interpolate(const std::vector<JointRecord>& s, double t) {
  SCARATWIN_CHECK(!s.empty(), "interpolate on an empty series");
  if (t <= s.front().t_s) return s.front().q;
  if (t >= s.back().t_s) return s.back().q;
  const auto it = std::upper_bound(s.begin(), s.end(), t,
                                   [](double x, const JointRecord& r) { return x < r.t_s; });
  const JointRecord& b = *it;
  const JointRecord& a = *(it - 1);
  const double u = b.t_s > a.t_s ? (t - a.t_s) / (b.t_s - a.t_s) : 0.0;
  JointVector q;
  for (int j = 0; j < kNumJoints; ++j) q[j] = a.q[j] + u * (b.q[j] - a.q[j]);
  return q;
}

double tool_distance(const RobotModel& model, const JointVector& a, const JointVector& b) {
  const ToolPose pa = forward(model, a), pb = forward(model, b);
  return std::hypot(pa.x_m - pb.x_m, pa.y_m - pb.y_m, pa.z_m - pb.z_m);
}

Deviation compare_runs(const RobotModel& model, const std::vector<JointRecord>& a,
                       const std::vector<JointRecord>& b, double offset) {
  Deviation d;
  if (a.empty() || b.empty()) return d;
  std::array<double, kNumJoints> sq{};
  double tool_sq = 0.0;
  size_t n = 0;
  for (const JointRecord& r : a) {
    const double tb = r.t_s + offset;
    if (tb < b.front().t_s || tb > b.back().t_s) continue;
    const JointVector qb = interpolate(b, tb);
    for (int j = 0; j < kNumJoints; ++j) {
      const double e = std::abs(qb[j] - r.q[j]);
      sq[j] += e * e;
      d.joint_max[j] = std::max(d.joint_max[j], e);
    }
    const double te = tool_distance(model, r.q, qb);
    tool_sq += te * te;
    d.tool_max_m = std::max(d.tool_max_m, te);
    d.t_s.push_back(r.t_s);
    d.tool_err_m.push_back(te);
    ++n;
  }
  if (n == 0) return d;
  for (int j = 0; j < kNumJoints; ++j) d.joint_rms[j] = std::sqrt(sq[j] / static_cast<double>(n));
  d.tool_rms_m = std::sqrt(tool_sq / static_cast<double>(n));
  d.tool_final_m = tool_distance(model, a.back().q, b.back().q);
  return d;
}

bool DesyncMonitor::check(const RobotModel& model, const JointVector& expected,
                          const JointVector& observed) {
  last_m_ = tool_distance(model, expected, observed);
  worst_m_ = std::max(worst_m_, last_m_);
  over_ = last_m_ > threshold_m_ ? over_ + 1 : 0;
  if (!raised_ && over_ >= persist_) {
    raised_ = true;
    return true;
  }
  return false;
}

}  // namespace scaratwin
