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

SampleClock::SampleClock(std::size_t window, double wire_s)
    : window_(std::max<std::size_t>(window, 1)),
      wire_us_(static_cast<int64_t>(std::llround(wire_s * 1e6))) {}

void SampleClock::reset() {
  started_ = false;
  n_ = 0;
  mins_.clear();
}

int64_t SampleClock::sample_time_us(uint32_t device_t_us, int64_t rx_us) {
  constexpr int64_t kJumpUs = 60'000'000;
  const auto step = static_cast<int32_t>(device_t_us - last_dev_);
  if (started_ && (step < 0 || step > kJumpUs)) reset();
  if (!started_) {
    started_ = true;
    dev_ = device_t_us;
  } else {
    dev_ += step;
  }
  last_dev_ = device_t_us;
  const int64_t offset = rx_us - dev_;
  while (!mins_.empty() && mins_.back().second >= offset) mins_.pop_back();
  mins_.emplace_back(n_, offset);
  while (mins_.front().first + window_ <= n_) mins_.pop_front();
  ++n_;
  return dev_ + mins_.front().second - wire_us_;
}

namespace {

JointVector lerp(const JointVector& a, const JointVector& b, double u) {
  JointVector q;
  for (int j = 0; j < kNumJoints; ++j) q[j] = a[j] + u * (b[j] - a[j]);
  return q;
}

// Sums of a Deviation: one pair of states (A's at time t, B's matched to it) at a time.
class DeviationSum {
 public:
  void add(const RobotModel& model, double t_s, const JointVector& qa, const JointVector& qb) {
    for (int j = 0; j < kNumJoints; ++j) {
      const double e = std::abs(qb[j] - qa[j]);
      sq_[j] += e * e;
      d_.joint_max[j] = std::max(d_.joint_max[j], e);
    }
    const double te = tool_distance(model, qa, qb);
    tool_sq_ += te * te;
    d_.tool_max_m = std::max(d_.tool_max_m, te);
    d_.t_s.push_back(t_s);
    d_.tool_err_m.push_back(te);
  }
  // The RMS figures, and the final deviation between the runs' last states.
  Deviation finish(const RobotModel& model, const JointVector& a_last, const JointVector& b_last) {
    const auto n = static_cast<double>(d_.t_s.size());
    if (n == 0) return d_;
    for (int j = 0; j < kNumJoints; ++j) d_.joint_rms[j] = std::sqrt(sq_[j] / n);
    d_.tool_rms_m = std::sqrt(tool_sq_ / n);
    d_.tool_final_m = tool_distance(model, a_last, b_last);
    return d_;
  }

 private:
  Deviation d_;
  std::array<double, kNumJoints> sq_{};
  double tool_sq_ = 0.0;
};

}  // namespace

JointVector interpolate(const std::vector<JointRecord>& s, double t) {
  SCARATWIN_CHECK(!s.empty(), "interpolate on an empty series");
  if (t <= s.front().t_s) return s.front().q;
  if (t >= s.back().t_s) return s.back().q;
  const auto it = std::upper_bound(s.begin(), s.end(), t,
                                   [](double x, const JointRecord& r) { return x < r.t_s; });
  const JointRecord& b = *it;
  const JointRecord& a = *(it - 1);
  return lerp(a.q, b.q, b.t_s > a.t_s ? (t - a.t_s) / (b.t_s - a.t_s) : 0.0);
}

double tool_distance(const RobotModel& model, const JointVector& a, const JointVector& b) {
  const ToolPose pa = forward(model, a), pb = forward(model, b);
  return std::hypot(pa.x_m - pb.x_m, pa.y_m - pb.y_m, pa.z_m - pb.z_m);
}

double lost_steps_tool_offset_m(const RobotModel& model, const std::array<double, 3>& counts,
                                const std::array<std::int32_t, 3>& offset_steps, double wrist_deg) {
  std::array<double, 3> truth = counts;
  for (std::size_t i = 0; i < truth.size(); ++i) truth[i] -= offset_steps[i];
  return tool_distance(model, motors_to_joints(model, counts, wrist_deg),
                       motors_to_joints(model, truth, wrist_deg));
}

namespace {

// Weight of an arm angle (J2, J3) against a length when finding the nearest point of a plan:
// about the length of the arm's links, so a radian counts like the tool moving 0.1 m. The
// wrist (J4) weighs nothing: it turns the tool without moving it, and the robot's servo takes
// each point's angle at once while the steppers glide between points, so in a fast turn its
// reported angle trails the plan by up to a point's worth.
constexpr double kRadianWeightM = 0.1;
constexpr double kJointWeight[kNumJoints] = {1.0, kRadianWeightM, kRadianWeightM, 0.0};
// Cost of skipping along the plan when following a run's progress, per metre of path skipped:
// the descent to a cube and the lift after the grip pass the same poses, and the earlier one
// is the run's. Small: a run off the path by e keeps lagging its true progress until that is
// 2 * kSkipCost * e behind, which overstates its deviation by 2 %.
constexpr double kSkipCost = 0.1;

double weighted_distance2(const JointVector& a, const JointVector& b) {
  double s = 0.0;
  for (int j = 0; j < kNumJoints; ++j) {
    const double d = (a[j] - b[j]) * kJointWeight[j];
    s += d * d;
  }
  return s;
}

// Point of segment [qa, qb] nearest to q in the weighted metric: the parameter in [0, 1].
double project_on_segment(const JointVector& qa, const JointVector& qb, const JointVector& q) {
  double num = 0.0, den = 0.0;
  for (int j = 0; j < kNumJoints; ++j) {
    const double w = kJointWeight[j] * kJointWeight[j];
    const double d = qb[j] - qa[j];
    num += w * (q[j] - qa[j]) * d;
    den += w * d * d;
  }
  return den > 0.0 ? std::clamp(num / den, 0.0, 1.0) : 0.0;
}

}  // namespace

PlanPoint nearest_on_plan(const RobotModel& model, const JointTrajectory& plan,
                          const JointVector& q, double from_s, double to_s, double skip_cost) {
  const auto& s = plan.samples;
  SCARATWIN_CHECK(!s.empty(), "nearest_on_plan on an empty plan");
  if (s.size() == 1) return {s.front().t_s, tool_distance(model, s.front().q, q)};
  // the segments that overlap [from_s, to_s]; the first one starts at from_s
  auto first = std::upper_bound(s.begin(), s.end(), from_s,
                                [](double t, const JointSample& x) { return t < x.t_s; });
  std::size_t k = first == s.begin() ? 0 : static_cast<std::size_t>(first - s.begin()) - 1;
  k = std::min(k, s.size() - 2);
  double seg_t = std::clamp(from_s, s[k].t_s, s[k + 1].t_s);
  JointVector seg_q = sample_at(plan, seg_t);
  double skipped = 0.0;  // path length from the point at from_s to the segment's start
  double best_cost = INFINITY, best_t = seg_t;
  JointVector best_q = seg_q;
  for (; k + 1 < s.size(); ++k) {
    const JointSample& b = s[k + 1];
    if (seg_t > to_s) break;
    const double u = project_on_segment(seg_q, b.q, q);
    const double t = seg_t + u * (b.t_s - seg_t);
    const JointVector p = lerp(seg_q, b.q, u);
    const double cost = std::sqrt(weighted_distance2(p, q)) +
                        skip_cost * (skipped + std::sqrt(weighted_distance2(seg_q, p)));
    if (cost < best_cost) {  // strict: the earliest of equally near points
      best_cost = cost;
      best_t = t;
      best_q = p;
    }
    skipped += std::sqrt(weighted_distance2(seg_q, b.q));
    seg_t = b.t_s;
    seg_q = b.q;
  }
  return {best_t, tool_distance(model, best_q, q)};
}

std::vector<double> plan_progress(const RobotModel& model, const JointTrajectory& plan,
                                  const std::vector<JointRecord>& run, double window_s) {
  std::vector<double> progress;
  progress.reserve(run.size());
  PlanTracker tracker(plan, window_s);
  for (const JointRecord& r : run) progress.push_back(tracker.follow(model, r.q).t_s);
  return progress;
}

PlanTracker::PlanTracker(const JointTrajectory& plan, double window_s)
    : plan_(&plan),
      window_s_(window_s),
      at_(plan.samples.empty() ? 0.0 : plan.samples.front().t_s) {}

PlanPoint PlanTracker::follow(const RobotModel& model, const JointVector& q) {
  const PlanPoint p = nearest_on_plan(model, *plan_, q, at_, at_ + window_s_, kSkipCost);
  at_ = p.t_s;
  return p;
}

Deviation compare_runs_by_progress(const RobotModel& model, const JointTrajectory& plan,
                                   const std::vector<JointRecord>& a,
                                   const std::vector<JointRecord>& b) {
  if (a.empty() || b.empty() || plan.samples.empty()) return {};
  const std::vector<double> pa = plan_progress(model, plan, a);
  const std::vector<double> pb = plan_progress(model, plan, b);
  DeviationSum sum;
  for (std::size_t i = 0; i < a.size(); ++i) {
    // B's state at A's progress: between the last B sample at or before it and the next one
    const auto it = std::upper_bound(pb.begin(), pb.end(), pa[i]);
    JointVector qb;
    if (it == pb.begin()) {
      qb = b.front().q;
    } else if (it == pb.end()) {
      qb = b.back().q;
    } else {
      const std::size_t j = static_cast<std::size_t>(it - pb.begin());
      const double span = pb[j] - pb[j - 1];
      qb = lerp(b[j - 1].q, b[j].q, span > 0.0 ? (pa[i] - pb[j - 1]) / span : 0.0);
    }
    sum.add(model, a[i].t_s, a[i].q, qb);
  }
  return sum.finish(model, a.back().q, b.back().q);
}

JointTrajectory as_plan(const std::vector<JointRecord>& run) {
  JointTrajectory plan;
  plan.samples.reserve(run.size());
  for (const JointRecord& r : run) {
    if (!plan.samples.empty() && r.t_s <= plan.samples.back().t_s) continue;  // keep time order
    plan.samples.push_back(JointSample{r.t_s, r.q, {}, {}});
  }
  return plan;
}

Deviation compare_runs(const RobotModel& model, const std::vector<JointRecord>& a,
                       const std::vector<JointRecord>& b, double offset) {
  if (a.empty() || b.empty()) return {};
  DeviationSum sum;
  for (const JointRecord& r : a) {
    const double tb = r.t_s + offset;
    if (tb < b.front().t_s || tb > b.back().t_s) continue;
    sum.add(model, r.t_s, r.q, interpolate(b, tb));
  }
  return sum.finish(model, a.back().q, b.back().q);
}

bool DesyncMonitor::check(const RobotModel& model, const JointVector& expected,
                          const JointVector& observed) {
  return check(tool_distance(model, expected, observed));
}

bool DesyncMonitor::check(double deviation_m) {
  last_m_ = deviation_m;
  worst_m_ = std::max(worst_m_, last_m_);
  over_ = last_m_ > threshold_m_ ? over_ + 1 : 0;
  if (over_ != persist_) return false;
  raised_ = true;
  ++alarms_;
  return true;
}

ToolErrorStats error_stats(std::vector<double> d) {
  ToolErrorStats s;
  s.count = d.size();
  if (d.empty()) return s;
  double sum = 0.0;
  for (double x : d) sum += x;
  s.mean_m = sum / static_cast<double>(d.size());
  std::sort(d.begin(), d.end());
  s.max_m = d.back();
  // nearest rank
  const auto rank = static_cast<std::size_t>(std::ceil(0.95 * static_cast<double>(d.size())));
  s.p95_m = d[std::max<std::size_t>(rank, 1) - 1];
  return s;
}

ToolErrorStats tool_error_vs_truth(const RobotModel& model, const std::vector<TimedJoints>& reports,
                                   const std::vector<ToolTruth>& truth, double max_gap_s,
                                   std::vector<double>* distances_m) {
  std::vector<double> d;
  std::size_t k = 0;
  for (const ToolTruth& tt : truth) {
    while (k + 1 < reports.size() && reports[k + 1].t_s < tt.t_s) ++k;
    if (k + 1 >= reports.size() || reports[k].t_s > tt.t_s) continue;
    const TimedJoints& a = reports[k];
    const TimedJoints& b = reports[k + 1];
    const double gap = b.t_s - a.t_s;
    if (!(gap > 0.0) || gap > max_gap_s) continue;
    const double w = (tt.t_s - a.t_s) / gap;
    JointVector q{};
    for (int j = 0; j < kNumJoints; ++j) q[j] = a.q[j] + w * (b.q[j] - a.q[j]);
    const ToolPose v = forward(model, q);
    d.push_back(std::hypot(v.x_m - tt.p_m[0], v.y_m - tt.p_m[1], v.z_m - tt.p_m[2]));
  }
  if (distances_m != nullptr) distances_m->insert(distances_m->end(), d.begin(), d.end());
  return error_stats(std::move(d));
}

}  // namespace scaratwin
