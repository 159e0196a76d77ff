// Twin database, figures, reports and the statement language.
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include "scaratwin/core/units.hpp"
#include "scaratwin/hub/analysis.hpp"
#include "scaratwin/hub/report.hpp"
#include "scaratwin/hub/script.hpp"
#include "scaratwin/hub/twin_db.hpp"

namespace scaratwin {
namespace {

namespace fs = std::filesystem;

fs::path temp_dir(const char* name) {
  fs::path p = fs::temp_directory_path() / fmt::format("scaratwin-{}-{}", name, getpid());
  fs::remove_all(p);
  fs::create_directories(p);
  return p;
}

std::string read_file(const fs::path& p) {
  std::ifstream in(p);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

TEST(TwinDb, KeepsEverythingAcrossReopen) {
  const fs::path dir = temp_dir("db");
  int64_t run = 0;
  {
    auto db = TwinDb::open(dir / "twin.db");
    ASSERT_TRUE(db) << db.error().message;
    auto r = (*db)->begin_run("mirror", "test");
    ASSERT_TRUE(r);
    run = *r;
    for (int i = 0; i < 5000; ++i) {
      JointRecord rec{i * 0.01, i % 65536, {0.1, 0.01 * i, -0.01 * i, 0.5}, 10.0};
      ASSERT_TRUE((*db)->add_sample(run, SampleSource::kPhysical, rec));
      ASSERT_TRUE((*db)->add_latency(run, {i, i * 10000, i * 10000 + 5000, i * 10000 + 5300}));
    }
    ASSERT_TRUE((*db)->add_event(run, 1.0, "alarm", "desync, 3 mm"));
    ASSERT_TRUE((*db)->add_metric(run, metric::kLostFrames, 0, "frames"));
    ASSERT_TRUE((*db)->add_image(run, 2.0, "shot.png", std::string("\x89PNG\r\n\x1a\n\0x", 10)));
    ASSERT_TRUE((*db)->end_run(run, "ok", 50.0));
  }
  auto db = TwinDb::open(dir / "twin.db");
  ASSERT_TRUE(db);
  auto samples = (*db)->samples(run, SampleSource::kPhysical);
  ASSERT_TRUE(samples);
  ASSERT_EQ(samples->size(), 5000u);
  EXPECT_DOUBLE_EQ((*samples)[4999].q[1], 0.01 * 4999);
  EXPECT_EQ((*samples)[12].seq, 12);
  EXPECT_EQ(*(*db)->count("latencies", run), 5000);
  EXPECT_EQ(*(*db)->count("images", run), 1);
  auto info = (*db)->run(run);
  ASSERT_TRUE(info);
  EXPECT_EQ(info->status, "ok");
  EXPECT_EQ(info->kind, "mirror");
  EXPECT_FALSE((*db)->count("no_such_table", run));
  EXPECT_FALSE((*db)->run(9999));
  // WAL mode: the write-ahead log sits beside the database while it is open.
  EXPECT_TRUE(fs::exists(dir / "twin.db-wal"));
  // CSV export.
  ASSERT_TRUE((*db)->export_csv(run, dir / "csv"));
  const std::string csv = read_file(dir / "csv" / "samples.csv");
  EXPECT_EQ(csv.rfind("source,t_s,seq,d1_m", 0), 0u);
  EXPECT_EQ(std::count(csv.begin(), csv.end(), '\n'), 5001);
  EXPECT_NE(read_file(dir / "csv" / "events.csv").find("\"desync, 3 mm\""), std::string::npos);
  fs::remove_all(dir);
}

// issue 17: `kill -9` of a recording hub left its run 'running' forever. The next open marks
// it 'aborted' (what it recorded stays); a run whose process lives stays 'running'.
TEST(TwinDb, RunOfAKilledProcessIsMarkedAbortedOnTheNextOpen) {
  const fs::path dir = temp_dir("aborted");
  const fs::path path = dir / "twin.db";
  int ready[2];
  ASSERT_EQ(::pipe(ready), 0);
  const pid_t child = ::fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    // the recording process: a run begun, a sample committed, then killed mid-run
    auto db = TwinDb::open(path);
    if (!db) ::_exit(3);
    auto run = (*db)->begin_run("mirror", "killed");
    if (!run) ::_exit(4);
    (void)(*db)->add_sample(*run, SampleSource::kPhysical, {0.5, 7, {0.1, 0.2, 0.3, 0.4}, 0.0});
    (void)(*db)->flush();
    const char ok = 'k';
    (void)!::write(ready[1], &ok, 1);
    for (;;) ::pause();
  }
  ::close(ready[1]);
  char got = 0;
  ASSERT_EQ(::read(ready[0], &got, 1), 1);
  ::close(ready[0]);
  // a live run of this process, in the same file
  auto live = TwinDb::open(path);
  ASSERT_TRUE(live) << live.error().message;
  auto mine = (*live)->begin_run("script", "alive");
  ASSERT_TRUE(mine);
  ASSERT_TRUE((*live)->flush());
  ASSERT_EQ(::kill(child, SIGKILL), 0);
  int status = 0;
  ASSERT_EQ(::waitpid(child, &status, 0), child);
  auto db = TwinDb::open(path);
  ASSERT_TRUE(db) << db.error().message;
  auto runs = (*db)->runs();
  ASSERT_TRUE(runs);
  ASSERT_EQ(runs->size(), 2u);
  EXPECT_EQ((*runs)[0].label, "killed");
  EXPECT_EQ((*runs)[0].status, "aborted");
  EXPECT_EQ((*runs)[1].label, "alive");
  EXPECT_EQ((*runs)[1].status, "running");
  auto kept = (*db)->samples((*runs)[0].id, SampleSource::kPhysical);
  ASSERT_TRUE(kept);
  ASSERT_EQ(kept->size(), 1u);
  EXPECT_EQ((*kept)[0].seq, 7);
  ASSERT_TRUE((*live)->end_run(*mine, "ok", 1.0));
}

TEST(TwinDb, RefusesAnUnwritablePath) {
  auto db = TwinDb::open("/proc/forbidden/twin.db");
  ASSERT_FALSE(db);
  EXPECT_NE(db.error().message.find("/proc/forbidden/twin.db"), std::string::npos);
}

TEST(Analysis, SummarizesAndCountsLostFrames) {
  const Stats s = summarize({1, 2, 3, 4, 100});
  EXPECT_DOUBLE_EQ(s.mean, 22.0);
  EXPECT_DOUBLE_EQ(s.p50, 3.0);
  EXPECT_DOUBLE_EQ(s.max, 100.0);
  std::vector<LatencyRecord> f;
  // seq 65534, 65535, 0, 3 (two lost across the wrap), device clock wrapping too.
  const int64_t seqs[] = {65534, 65535, 0, 3};
  for (int i = 0; i < 4; ++i) {
    const int64_t dev = (4294967296LL - 20000 + i * 10000) % 4294967296LL;
    const int64_t hub = 1000000 + i * 10000 + (i == 3 ? 2000 : 0);
    f.push_back({seqs[i], dev, hub, hub + 500});
  }
  const LatencyFigures lf = latency_figures(f, 0.004);
  EXPECT_EQ(lf.lost_frames, 2);
  EXPECT_NEAR(lf.hub_to_sim_ms.mean, 0.5, 1e-9);
  // the fastest frames took wire time + 0.5 ms; the late one 2 ms more.
  EXPECT_NEAR(lf.device_to_sim_ms.p50, 4.5, 1e-9);
  EXPECT_NEAR(lf.device_to_sim_ms.max, 6.5, 1e-9);
}

// The online alignment against the true sample times of a made-up robot: its clock starts at
// 2^32 - 0.5 s (wraps after 50 reports) and runs 0.1 % fast; every report takes its wire time
// (4 ms) plus a queueing delay that is 0 for one report in ten and 1-9 ms otherwise. Once a
// report with no delay is in the window, the sample time is exact to the drift over the window
// (1 s at 0.1 %: 1 ms at most); the robot's restart starts the window again.
TEST(Analysis, SampleClockFindsTheSampleTimesOnline) {
  SampleClock clock(100, 0.004);
  const int64_t host0 = 5'000'000'000;  // the host's clock at the first sample, us
  double worst_us = 0.0;
  for (int i = 0; i < 300; ++i) {
    const int64_t sample = host0 + i * 10'000;
    const auto dev = static_cast<uint32_t>(4294967296LL - 500'000 + std::llround(i * 10'010.0));
    const int64_t delay = i % 10 == 0 ? 0 : 1000 * (i % 10);
    const int64_t t = clock.sample_time_us(dev, sample + 4000 + delay);
    if (i >= 10) worst_us = std::max(worst_us, std::abs(static_cast<double>(t - sample)));
    if (i == 0) {
      EXPECT_EQ(t, sample) << "the first report had no delay";
    }
  }
  EXPECT_LT(worst_us, 1000.0);
  // a restart: the robot's clock from 0 again, the host's on; no report of the old clock counts
  // (the first one after it, 3 ms late, is all there is to go by; the next one was on time)
  const int64_t host1 = host0 + 10'000'000;
  EXPECT_EQ(clock.sample_time_us(1000, host1 + 4000 + 3000), host1 + 3000);
  EXPECT_EQ(clock.sample_time_us(11'000, host1 + 10'000 + 4000), host1 + 10'000);
}

TEST(Analysis, ComparesRunsAndRaisesDesync) {
  const RobotModel m = paper_robot();
  std::vector<JointRecord> a, b;
  for (int i = 0; i <= 100; ++i) {
    a.push_back({i * 0.01, i, {0.1, 0.3 * i / 100.0, 0.5, 1.0}, 0});
    b.push_back({i * 0.01, i, {0.1, 0.3 * i / 100.0, 0.5, 1.0}, 0});
  }
  Deviation same = compare_runs(m, a, b);
  EXPECT_DOUBLE_EQ(same.tool_max_m, 0.0);
  for (auto& r : b) r.q[0] += 0.002;  // 2 mm lower/higher in Z
  Deviation d = compare_runs(m, a, b);
  EXPECT_NEAR(d.tool_max_m, 0.002, 1e-12);
  EXPECT_NEAR(d.joint_rms[0], 0.002, 1e-12);
  EXPECT_NEAR(d.tool_final_m, 0.002, 1e-12);

  DesyncMonitor mon(0.003, 3);
  const JointVector q{0.1, 0.2, 0.3, 0.4};
  JointVector slipped = q;
  slipped[1] += 100.0 / 945.0;  // 100 lost steps on J2
  EXPECT_FALSE(mon.check(m, q, q));
  EXPECT_FALSE(mon.check(m, q, slipped));
  EXPECT_FALSE(mon.check(m, q, slipped));
  EXPECT_TRUE(mon.check(m, q, slipped));
  EXPECT_FALSE(mon.check(m, q, slipped));  // raised once
  EXPECT_TRUE(mon.raised());
  EXPECT_GT(mon.worst_deviation_m(), 0.003);
  // back on the path, then off again for a whole streak: a second alarm
  EXPECT_FALSE(mon.check(m, q, q));
  EXPECT_FALSE(mon.check(0.004));
  EXPECT_FALSE(mon.check(0.004));
  EXPECT_TRUE(mon.check(0.004));
  EXPECT_EQ(mon.alarms(), 2);
}

// What homing again measures, at the tool: nothing lost, nothing off; steps lost on J2 move
// the tool as the joints the counts give and the joints the motors are at differ; on Z, a lift.
TEST(Analysis, LostStepsBecomeAToolOffset) {
  const RobotModel m = paper_robot();
  const std::array<double, 3> home_counts = {24667, 0, 0};
  EXPECT_EQ(lost_steps_tool_offset_m(m, home_counts, {0, 0, 0}, 90.0), 0.0);
  const JointVector counted = motors_to_joints(m, home_counts, 90.0);
  const JointVector real = motors_to_joints(m, {24667, -100, 0}, 90.0);
  const double expected = tool_distance(m, counted, real);
  EXPECT_GT(expected, 0.003) << "100 J2 steps move the tool by more than the alarm threshold";
  EXPECT_DOUBLE_EQ(lost_steps_tool_offset_m(m, home_counts, {0, 100, 0}, 90.0), expected);
  EXPECT_NEAR(lost_steps_tool_offset_m(m, home_counts, {-400, 0, 0}, 90.0),
              400.0 / m.motors.z.steps_per_unit, 1e-12)
      << "Z: a pure lift";
}

// A plan out and back (shoulder 0 -> 0.6 rad -> 0), and runs of it at other paces.
JointTrajectory out_and_back() {
  JointTrajectory plan;
  for (int i = 0; i <= 200; ++i) {
    const double u = i <= 100 ? i / 100.0 : (200 - i) / 100.0;
    plan.samples.push_back({i * 0.01, {0.1, 0.6 * u, 0.5, 0.0}, {}, {}});
  }
  return plan;
}

std::vector<JointRecord> run_of(const JointTrajectory& plan, double start_s, double rate,
                                double pause_at_s, double pause_s, double dz_m) {
  std::vector<JointRecord> run;
  const double end_s = start_s + plan.duration_s() / rate + pause_s + 0.5;
  for (double t = 0.0; t <= end_s; t += 0.01) {
    double tp = (t - start_s) * rate;  // plan time reached
    if (tp > pause_at_s) tp = std::max(pause_at_s, tp - pause_s * rate);
    JointVector q = sample_at(plan, tp);
    q[0] += dz_m;
    run.push_back({t, static_cast<std::int64_t>(run.size()), q, 0.0});
  }
  return run;
}

TEST(Analysis, ComparesRunsOfOnePlanByProgressNotByTime) {
  const RobotModel m = paper_robot();
  const JointTrajectory plan = out_and_back();
  const auto a = run_of(plan, 0.3, 1.0, 99.0, 0.0, 0.0);
  // B starts later, runs 10 % slower and pauses 0.4 s at the turn: the same path
  const auto b = run_of(plan, 0.8, 0.9, 1.0, 0.4, 0.0);
  const Deviation by_time = compare_runs(m, a, b);
  EXPECT_GT(by_time.tool_max_m, 0.02) << "timing alone separates the runs by time";
  const Deviation d = compare_runs_by_progress(m, plan, a, b);
  EXPECT_LT(d.tool_max_m, 2e-4);
  EXPECT_LT(d.tool_final_m, 1e-9);
  // progress is monotonic and spans the plan; the way back is not mistaken for the way out
  const auto pb = plan_progress(m, plan, b);
  ASSERT_EQ(pb.size(), b.size());
  EXPECT_TRUE(std::is_sorted(pb.begin(), pb.end()));
  EXPECT_NEAR(pb.back(), 2.0, 1e-9);
  EXPECT_NEAR(pb[static_cast<std::size_t>((0.8 + 1.5 / 0.9 + 0.4) / 0.01)], 1.5, 0.02);
  // the prediction itself as the plan gives the same answer
  const Deviation self = compare_runs_by_progress(m, as_plan(a), a, b);
  EXPECT_LT(self.tool_max_m, 2e-4);
  // a real deviation counts in full: 2 mm in Z all along
  const auto c = run_of(plan, 0.8, 0.9, 1.0, 0.4, 0.002);
  const Deviation dz = compare_runs_by_progress(m, plan, a, c);
  EXPECT_NEAR(dz.tool_max_m, 0.002, 2e-4);
  EXPECT_NEAR(dz.tool_final_m, 0.002, 1e-9);
  // nearest_on_plan: distance to the path within the window only
  const PlanPoint near = nearest_on_plan(m, plan, sample_at(plan, 0.5), 0.0, 2.0);
  EXPECT_NEAR(near.t_s, 0.5, 1e-9);
  EXPECT_LT(near.tool_distance_m, 1e-12);
  const PlanPoint back = nearest_on_plan(m, plan, sample_at(plan, 0.5), 1.2, 2.0);
  EXPECT_NEAR(back.t_s, 1.5, 1e-9) << "the same pose on the way back";
  const PlanPoint late = nearest_on_plan(m, plan, sample_at(plan, 0.5), 0.8, 1.2);
  EXPECT_GT(late.tool_distance_m, 0.01) << "outside the window the pose is off the path";
}

// The hub's desync alarm follows a run report by report with a PlanTracker: a robot that holds
// for seconds on an empty queue or whose clock runs slow stays on its path (no alarm); steps
// lost half-way move it off the path for good (one alarm).
TEST(Analysis, PlanTrackerAlarmsOnLeavingThePathNotOnRunningLate) {
  const RobotModel m = paper_robot();
  const JointTrajectory plan = out_and_back();
  const auto check_run = [&](const std::vector<JointRecord>& run, double* worst_m) {
    PlanTracker tracker(plan, 1.5);
    DesyncMonitor mon(0.003, 5);
    double last = 0.0;
    for (const JointRecord& r : run) {
      const PlanPoint p = tracker.follow(m, r.q);
      EXPECT_GE(p.t_s, last) << "progress never goes back";
      last = p.t_s;
      (void)mon.check(p.tool_distance_m);
    }
    EXPECT_NEAR(tracker.progress_s(), 2.0, 1e-9);
    *worst_m = mon.worst_deviation_m();
    return mon.alarms();
  };
  double worst = 0.0;
  // starts 1 s late, runs at half speed, holds 3 s at the turn: 9 s of a 2 s plan
  EXPECT_EQ(check_run(run_of(plan, 1.0, 0.5, 1.0, 3.0, 0.0), &worst), 0);
  EXPECT_LT(worst, 1e-6);
  // the same run with 3 mm lost in Z from the turn on (after 1 s of plan time)
  auto slipped = run_of(plan, 1.0, 0.5, 1.0, 3.0, 0.0);
  for (std::size_t i = slipped.size() / 2; i < slipped.size(); ++i) slipped[i].q[0] += 0.004;
  EXPECT_EQ(check_run(slipped, &worst), 1);
  EXPECT_NEAR(worst, 0.004, 1e-4);
}

// The robot's wrist is a servo that takes each point's angle when the point starts, while the
// steppers move smoothly between points: in a fast turn the reported wrist trails the plan by
// up to a point's angle. The tool's position does not depend on it and neither may its
// distance from the path.
TEST(Analysis, PlanTrackerIgnoresTheWristStepsOfAFastTurn) {
  const RobotModel m = paper_robot();
  const JointTrajectory plan = quintic({0.09, -0.3, 1.9, 0.0}, {0.09, -1.5, 1.4, 1.6}, 1.2, 60);
  PlanTracker tracker(plan, 1.5);
  DesyncMonitor mon(0.003, 5);
  for (double t = 0.0; t <= 1.3; t += 0.01) {
    JointVector q = sample_at(plan, t);
    q[3] = sample_at(plan, std::floor(t / 0.02) * 0.02)[3];  // the servo at the point's angle
    (void)mon.check(tracker.follow(m, q).tool_distance_m);
  }
  EXPECT_EQ(mon.alarms(), 0);
  EXPECT_LT(mon.worst_deviation_m(), 1e-4);
  EXPECT_NEAR(tracker.progress_s(), 1.2, 1e-9);
}

TEST(Report, WritesPlotsAndThePapersFigures) {
  const fs::path dir = temp_dir("report");
  auto db = TwinDb::open(dir / "twin.db");
  ASSERT_TRUE(db);
  auto demo = (*db)->begin_run("demo", "report test");
  auto mirror = (*db)->begin_run("mirror", "buttons", *demo);
  ASSERT_TRUE(demo && mirror);
  for (int i = 0; i < 200; ++i) {
    const JointVector q{0.1, std::sin(i * 0.05), 0.5, 1.0};
    ASSERT_TRUE((*db)->add_sample(*mirror, SampleSource::kPhysical, {i * 0.01, i, q, 0}));
    ASSERT_TRUE((*db)->add_sample(*mirror, SampleSource::kVirtual, {i * 0.01 + 0.004, i, q, 0}));
    ASSERT_TRUE((*db)->add_latency(*mirror, {i, i * 10000, i * 10000, i * 10000 + 300 + i}));
  }
  ASSERT_TRUE((*db)->add_metric(*mirror, metric::kLatencyMeanMs, 5.2, "ms"));
  ASSERT_TRUE((*db)->end_run(*mirror, "ok", 2.0));
  ASSERT_TRUE((*db)->end_run(*demo, "ok", 3.0));
  ASSERT_TRUE(write_report(**db, paper_robot(), *demo, dir / "report.html"));
  const std::string html = read_file(dir / "report.html");
  EXPECT_NE(html.find("Our figures beside the paper"), std::string::npos);
  EXPECT_NE(html.find("74.4 / 72.5 / 76.4"), std::string::npos);
  EXPECT_NE(html.find("<td>5.2</td>"), std::string::npos);
  EXPECT_GE(std::count(html.begin(), html.end(), '<'), 100);
  size_t svgs = 0;
  for (size_t p = html.find("<svg"); p != std::string::npos; p = html.find("<svg", p + 1)) ++svgs;
  EXPECT_GE(svgs, 8u);  // 4 joints, 2 path views, deviation, latency histogram
  EXPECT_NE(html.find("tool path, top view"), std::string::npos);
  EXPECT_NE(html.find("mirror latency"), std::string::npos);
  EXPECT_FALSE(write_report(**db, paper_robot(), 12345, dir / "x.html"));
  fs::remove_all(dir);
}

TEST(Script, ParsesStatementsInSiUnits) {
  auto s = parse_script(
      "# sort one cube\nhome\nspawn red 0.18 0.08\nmove 0.18 0.08 -0.02 90  # above\n"
      "\ngrip\nmovej 0.1 10 20 30\nwait 0.5\nshoot out.png\n",
      "demo.txt");
  ASSERT_TRUE(s) << s.error().message;
  ASSERT_EQ(s->size(), 7u);
  EXPECT_EQ((*s)[0].kind, StatementKind::kHome);
  EXPECT_EQ((*s)[1].kind, StatementKind::kSpawn);
  EXPECT_EQ((*s)[1].text, "red");
  EXPECT_EQ((*s)[2].line, 4);
  EXPECT_TRUE((*s)[2].has_yaw);
  EXPECT_NEAR((*s)[2].numbers[3], kPi / 2, 1e-15);
  EXPECT_NEAR((*s)[4].numbers[2], deg_to_rad(20), 1e-15);
  EXPECT_EQ((*s)[6].text, "out.png");
}

TEST(Script, ErrorsNameTheLine) {
  auto bad = parse_script("home\nmove 0.1 0.2\n", "a.txt");
  ASSERT_FALSE(bad);
  EXPECT_EQ(bad.error().message.rfind("a.txt:2: 'move' takes 3 to 4 numbers, got 2", 0), 0u)
      << bad.error().message;
  auto unknown = parse_script("home\n\nfly 1 2\n", "b.txt");
  ASSERT_FALSE(unknown);
  EXPECT_EQ(unknown.error().message.rfind("b.txt:3: unknown statement 'fly'", 0), 0u);
  auto nan = parse_script("move 0.1 nan 0\n", "c.txt");
  ASSERT_FALSE(nan);
  EXPECT_NE(nan.error().message.find("'nan' is not a number"), std::string::npos);
  auto color = parse_statement("spawn purple 0.1 0.1", 0);
  ASSERT_FALSE(color);
  EXPECT_NE(color.error().message.find("unknown colour 'purple'"), std::string::npos);
}

}  // namespace
}  // namespace scaratwin
