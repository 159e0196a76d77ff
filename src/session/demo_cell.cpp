// scaratwin demo --robots N: the robots of a workcell (config/two_arms_trays.toml) share one table
// in one simulator. Each robot is our firmware in the AVR emulator with a hub of its own, which
// names its robot in its hello (docs/protocol.md section 11.3) and mirrors it live. The cubes
// are split between the robots by reach and scheduled so that the arms keep their clearance on
// the planned paths (trajectory/workcell_plan.hpp) before anything moves; while they run, the
// simulator's contacts between the arms are watched, and a touch stops every robot.
#include "scaratwin/session/demo_cell.hpp"

#include <atomic>
#include <chrono>
#include <fstream>
#include <memory>
#include <thread>
#include <vector>

#include <fmt/format.h>

#include <nlohmann/json.hpp>

#include "scaratwin/config/robot_config.hpp"
#include "scaratwin/config/workcell_config.hpp"
#include "scaratwin/core/units.hpp"
#include "scaratwin/hub/analysis.hpp"
#include "scaratwin/hub/hub.hpp"
#include "scaratwin/hub/process.hpp"
#include "scaratwin/hub/report.hpp"
#include "scaratwin/hub/robot_interface.hpp"
#include "scaratwin/hub/tasks.hpp"
#include "scaratwin/kinematics/workcell.hpp"
#include "scaratwin/session/emulator_side.hpp"
#include "scaratwin/session/figures.hpp"
#include "scaratwin/sim/mjcf.hpp"
#include "scaratwin/trajectory/workcell_plan.hpp"
#include "scaratwin/transport/serial.hpp"

namespace scaratwin::session {
namespace {

using namespace std::chrono_literals;
namespace fs = std::filesystem;

// The planner keeps the arms' centre lines apart (trajectory/clearance.hpp); an arm is wider
// (sim::arm_half_width_m: its marker flag, 30 mm off the wrist axis, with the paper's cube).
// Apart by twice the widest arm's half width and 10 mm more, two arms do not touch.
double arm_half_width(const Workcell& cell) {
  double w = 0.0;
  for (int r = 0; r < static_cast<int>(cell.robots.size()); ++r) {
    // the gripper is sized for the workcell's cubes
    w = std::max(w, sim::arm_half_width_m(scene_in_base(cell, r)));
  }
  return w;
}
double clearance_m(const Workcell& cell) { return 2 * arm_half_width(cell) + 0.010; }

// One robot of the demo: its description with the scene in its base frame, its database and
// its hub.
struct Arm {
  std::string name;
  RobotModel model;
  std::unique_ptr<TwinDb> db;
  std::unique_ptr<Hub> hub;
  std::int64_t run = 0;
  std::uint64_t build_seed = 0;          // its as-built draw (ideal: unused)
  std::unique_ptr<TruthRecorder> truth;  // the measuring instrument (as built), else null
  int tasks = 0;
  std::string error;  // what ended its motion early
};

// Cube spots in W: cube k is drawn from robot (k mod n)'s workspace (tasks::random_layout in
// its base frame), kept apart from every other cube, off its own arm at home (as in the single
// demo) and far enough from every other arm at home for it to work there.
Result<std::vector<SortItem>> cell_layout(const Workcell& cell, unsigned seed, int cubes) {
  const int n = static_cast<int>(cell.robots.size());
  for (int attempt = 0; attempt < 50; ++attempt) {
    // cube k from robot k mod n, the colours in order (red, green, blue, ...)
    std::vector<SortItem> items(static_cast<std::size_t>(cubes));
    bool ok = true;
    for (int r = 0; r < n && ok; ++r) {
      int mine = 0;
      for (int k = r; k < cubes; k += n) ++mine;
      if (mine == 0) continue;
      const RobotModel m = scene_in_base(cell, r);
      auto spots =
          random_layout(m, seed + 1000u * static_cast<unsigned>(attempt) + r, mine, m.home);
      if (!spots) return spots.error();
      for (int j = 0; j < mine; ++j) {
        const SortItem& s = (*spots)[static_cast<std::size_t>(j)];
        const auto w = base_to_world(cell.robots[r].base, {s.x_m, s.y_m, 0.0});
        SortItem& it = items[static_cast<std::size_t>(r + j * n)];
        it = s;
        it.x_m = w[0];
        it.y_m = w[1];
        it.yaw_rad = s.yaw_rad + cell.robots[r].base.yaw_rad;
      }
    }
    for (int k = 0; k < cubes; ++k) {
      items[static_cast<std::size_t>(k)].color = static_cast<CubeColor>(k % kNumColors);
    }
    for (std::size_t i = 0; i < items.size() && ok; ++i) {
      const std::array<double, 3> p{items[i].x_m, items[i].y_m, 0.0};
      for (std::size_t j = 0; j < i; ++j) {
        if (std::hypot(items[i].x_m - items[j].x_m, items[i].y_m - items[j].y_m) < 0.045) {
          ok = false;
        }
      }
      // its own arm's camera clearance; another arm at home must let this one work there
      const int owner = static_cast<int>(i) % n;
      for (int r = 0; r < n && ok; ++r) {
        const double keep = r == owner ? kArmClearance_m : clearance_m(cell) + arm_half_width(cell);
        const auto pts = home_arm_points(cell, r);
        for (std::size_t s = 0; s + 1 < pts.size(); ++s) {
          if (distance_to_segment_xy(p, pts[s], pts[s + 1]) < keep) ok = false;
        }
      }
    }
    if (ok) return items;
  }
  return Error{static_cast<int>(HubError::kTask),
               "no layout of the cubes keeps them apart and off the arms (50 draws)"};
}

// One task per cube: pick it where it lies, place it in its colour's tray (the single demo's
// heights: grasp, and 4 mm above it to release).
std::vector<WorkcellTask> cell_tasks(const Workcell& cell, const std::vector<SortItem>& cubes) {
  std::vector<WorkcellTask> tasks;
  int per_color[kNumColors] = {};
  for (const SortItem& c : cubes) {
    const Tray& tray = cell.scene.trays[static_cast<std::size_t>(c.color)];
    tasks.push_back(WorkcellTask{
        fmt::format("{} cube {}", color_name(c.color), per_color[static_cast<int>(c.color)]++),
        ToolPose{c.x_m, c.y_m, cell.scene.grasp_z_m, c.yaw_rad},
        ToolPose{tray.x_m, tray.y_m, cell.scene.grasp_z_m + 0.004, 0.0}});
  }
  return tasks;
}

// Runs `body(arm)` for every arm at once; the first error, naming its robot.
template <class F>
Status for_each_at_once(std::vector<Arm>& arms, F body) {
  std::vector<Status> result(arms.size(), Status{Ok{}});
  std::vector<std::thread> threads;
  for (std::size_t i = 0; i < arms.size(); ++i) {
    threads.emplace_back([&, i] { result[i] = body(arms[i]); });
  }
  for (std::thread& t : threads) t.join();
  for (std::size_t i = 0; i < arms.size(); ++i) {
    if (!result[i]) {
      return Error{result[i].error().code, arms[i].name + ": " + result[i].error().message};
    }
  }
  return Ok{};
}

}  // namespace

Result<CellDemoResult> run_cell_demo(const Workcell& cell, const fs::path& file,
                                     const CellDemoOptions& a, const Say& say, const Say& warn) {
  const int n = static_cast<int>(cell.robots.size());
  const fs::path& out = a.out;
  auto interrupted = [&a] { return a.interrupted != nullptr && a.interrupted->load(); };
  say(fmt::format("scaratwin demo: {} robots ({}) of {}, results in {}", n, robot_names(cell),
                  file.string(), out.string()));

  // 1. the simulator of the whole workcell, and each robot with its hub
  auto started = start_simulator(
      sibling_executable("scaratwin-sim"),
      {"--workcell", file.string(), "--port", "0", "--http-port", std::to_string(a.http_port)},
      out / "sim.log", 30s);
  if (!started) return Error{AppError::kRigStart, "simulator: " + started.error().message};
  std::unique_ptr<ChildProcess> sim = std::move(started->process);
  const std::uint16_t port = started->ready.port;
  if (!started->ready.ui_url.empty()) say(fmt::format("3D view: {}", started->ready.ui_url));
  std::vector<Arm> arms(static_cast<std::size_t>(n));
  for (int i = 0; i < n; ++i) {
    Arm& arm = arms[static_cast<std::size_t>(i)];
    const RobotInstance& r = cell.robots[static_cast<std::size_t>(i)];
    arm.name = r.name;
    arm.model = scene_in_base(cell, i);
    auto db = TwinDb::open(out / fmt::format("twin-{}.db", r.name));
    if (!db) {
      return db.error();
    }
    arm.db = std::move(*db);
    EmulatedRobotOptions eo;
    eo.args = {"--speed", fmt::format("{}", a.robot_speed), "--camera-port", "-1"};
    if (a.ideal) {
      eo.args.insert(eo.args.end(), {"--plant", "ideal"});
    } else {
      // a build of its own: two arms of one description are two prints, not one
      arm.build_seed =
          static_cast<std::uint64_t>(a.as_built_seed >= 0
                                         ? a.as_built_seed
                                         : static_cast<long long>(r.model.physical.as_built.seed)) +
          static_cast<std::uint64_t>(i);
      eo.args.insert(eo.args.end(),
                     {"--plant", "as-built", "--as-built-seed", std::to_string(arm.build_seed)});
    }
    if (!r.description_file.empty()) {
      eo.args.insert(eo.args.end(), {"--config", r.description_file});
    }
    eo.log = out / fmt::format("robot-{}.log", r.name);
    HubOptions ho;
    ho.sim_port = port;
    ho.sim_robot = i;
    ho.base = r.base;
    ho.description_source = r.description_file;
    ho.log_name = r.name;
    auto hub = Hub::connect(arm.model, emulated_robot(eo), ho, arm.db.get());
    if (!hub) {
      return Error{hub.error().code, r.name + ": " + hub.error().message};
    }
    arm.hub = std::move(*hub);
    say(fmt::format(
        "robot {} '{}': firmware in the AVR emulator on {}, base at ({:.0f}, {:.0f}) mm, "
        "{:.0f} deg, {}",
        i, r.name, arm.hub->robot_interface().where(), m_to_mm(r.base.x_m), m_to_mm(r.base.y_m),
        rad_to_deg(r.base.yaw_rad),
        a.ideal ? std::string("exact (plant ideal)")
                : fmt::format("as built (seed {})", arm.build_seed)));
    if (!a.ideal) {
      // the truth of the robot as built: read only for the figures, as a tape measure is
      if (const std::uint16_t side = arm.hub->robot_interface().side_channel_port(); side != 0) {
        auto t = TruthRecorder::start(side, TruthRecorder::kDemoHz);
        if (!t) {
          return Error{t.error().code, r.name + ": " + t.error().message};
        }
        arm.truth = std::move(*t);
      }
    }
    auto run = arm.hub->begin_run(
        "cell-sort", fmt::format("robot {} '{}' of {}", i, r.name, file.filename().string()));
    if (!run) {
      return run.error();
    }
    arm.run = *run;
  }
  const auto t0 = std::chrono::steady_clock::now();

  auto fail = [&](const std::string& why) {
    warn(why);
    for (Arm& arm : arms) (void)arm.hub->end_run(false);
    return CellDemoResult{};
  };

  // 2. home every robot at once, mirrored
  say(fmt::format("==> [1/4] home every robot against its endstops"));
  if (Status s = for_each_at_once(
          arms,
          [](Arm& arm) {
            if (Status p = arm.hub->set_twin_phase(protocol::TwinPhase::kMirror); !p) {
              return p;
            }
            arm.hub->set_mirror(true);
            return arm.hub->home();
          });
      !s) {
    return fail(s.error().message);
  }

  // 3. the cubes, the tasks, and the plan, checked before anything moves
  say(fmt::format("==> [2/4] {} cubes on the table; the tasks split by reach and planned apart",
                  a.cubes));
  WorkcellPlanOptions po;
  po.pick_place.approach_height_m = cell.scene.approach_height_m;
  po.home_after_each = true;  // a waiting arm stands at home, not over a tray
  po.clearance.clearance_m = clearance_m(cell);
  std::vector<JointVector> start;
  for (Arm& arm : arms) start.push_back(arm.hub->physical().q);
  // a layout whose tasks the arms can share apart (some cannot: a cube whose tray only an arm
  // that would pass the other's home reaches), drawn again up to 20 times
  std::vector<SortItem> layout;
  for (int attempt = 0; attempt < 20; ++attempt) {
    auto drawn = cell_layout(cell, a.seed + 7919u * static_cast<unsigned>(attempt), a.cubes);
    if (!drawn) return fail(drawn.error().message);
    auto trial = plan_workcell_sort(cell, cell_tasks(cell, *drawn), start, po);
    if (trial) {
      layout = std::move(*drawn);
      break;
    }
    if (trial.error().code != static_cast<int>(PlanError::kCollision) || attempt == 19) {
      return fail("plan: " + trial.error().message);
    }
  }
  Hub& scene = *arms[0].hub;  // robot 0's base frame is the world frame
  for (const SortItem& it : layout) {
    if (auto id = scene.spawn_cube(it.color, it.x_m, it.y_m); !id) {
      return fail(id.error().message);
    }
  }
  std::this_thread::sleep_for(300ms);  // the cubes settle
  auto objects = scene.objects();
  if (!objects) return fail(objects.error().message);
  std::vector<SortItem> found;
  for (const protocol::ObjectPose& o : *objects) {
    found.push_back(SortItem{o.color, o.x_m, o.y_m, o.yaw_rad});
  }
  const std::vector<WorkcellTask> tasks = cell_tasks(cell, found);
  auto plan = plan_workcell_sort(cell, tasks, start, po);
  if (!plan) return fail("plan: " + plan.error().message);
  for (std::size_t t = 0; t < tasks.size(); ++t) {
    const int r = plan->robot_of_task[t];
    ++arms[static_cast<std::size_t>(r)].tasks;
    say(fmt::format("  {} at ({:.0f}, {:.0f}) mm -> {}", tasks[t].what,
                    m_to_mm(tasks[t].pick_W.x_m), m_to_mm(tasks[t].pick_W.y_m),
                    cell.robots[static_cast<std::size_t>(r)].name));
  }
  const ArmApproach& closest = plan->clearance.closest;
  say(fmt::format(
      "  planned: {:.1f} s; the arms at least {:.0f} mm apart seen from above (robots {} "
      "and {} at {:.1f} s; clearance {:.0f} mm, {} looks)",
      plan->makespan_s, m_to_mm(closest.bound_m), closest.robot_a, closest.robot_b, closest.t_s,
      m_to_mm(po.clearance.clearance_m), plan->clearance.looks));

  // 4. every robot runs its timeline at once, mirrored; the simulator's contacts are watched
  say(fmt::format("==> [3/4] the robots sort the cubes together, mirrored live"));
  auto contacts0 = scene.arm_contacts();
  if (!contacts0) return fail(contacts0.error().message);
  for (Arm& arm : arms) (void)arm.hub->set_twin_phase(protocol::TwinPhase::kControl);
  std::atomic<int> running{n};
  std::atomic<bool> touched{false};
  protocol::ArmContacts touch{};
  std::thread watch([&] {
    while (running.load() > 0) {
      std::this_thread::sleep_for(100ms);
      if (interrupted()) {
        for (Arm& arm : arms) arm.hub->interrupt();
      }
      auto c = scene.arm_contacts();
      if (c && c->count > contacts0->count && !touched.exchange(true)) {
        touch = *c;
        for (Arm& arm : arms) arm.hub->interrupt();  // stops each robot at once
      }
    }
  });
  const std::uint64_t sort_from_us = monotonic_us();
  Status ran = for_each_at_once(arms, [&](Arm& arm) -> Status {
    const std::size_t i = static_cast<std::size_t>(&arm - arms.data());
    auto r = arm.hub->run_trajectory(plan->timeline[i]);
    running.fetch_sub(1);
    if (!r) {
      arm.error = r.error().message;
      return r.error();
    }
    return Ok{};
  });
  watch.join();
  std::this_thread::sleep_for(500ms);  // the last cubes land
  const std::uint64_t sort_to_us = monotonic_us();

  // 5. the figures
  say(fmt::format("==> [4/4] figures"));
  auto final_objects = scene.objects();
  const int in_trays = final_objects ? cubes_in_trays(scene_in_base(cell, 0), *final_objects) : -1;
  auto contacts = scene.arm_contacts();
  const int touches = contacts ? contacts->count - contacts0->count : -1;
  const double dur = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  nlohmann::json j;
  j["workcell"] = file.string();
  j["cubes"] = a.cubes;
  j["in_trays"] = in_trays;
  j["arm_touches"] = touches;
  j["planned_makespan_s"] = plan->makespan_s;
  j["planned_least_distance_mm"] = m_to_mm(closest.bound_m);
  j["clearance_mm"] = m_to_mm(po.clearance.clearance_m);
  bool lossless = true;
  for (Arm& arm : arms) {
    const MirrorCounters mc = arm.hub->mirror_counters();
    lossless = lossless && mc.lost == 0;
    say(fmt::format("  {}: {} tasks; mirror {} frames, {} lost, mean latency {:.2f} ms{}", arm.name,
                    arm.tasks, mc.frames, mc.lost, mc.mean_latency_ms,
                    arm.error.empty() ? "" : "; stopped: " + arm.error));
    nlohmann::json rj = {{"name", arm.name},
                         {"tasks", arm.tasks},
                         {"frames", mc.frames},
                         {"lost", mc.lost},
                         {"mean_latency_ms", mc.mean_latency_ms},
                         {"stopped", arm.error},
                         {"plant", a.ideal ? "ideal" : "as-built"}};
    // the report's figures, each robot's in its own database
    Hub& hub = *arm.hub;
    if (arm.truth) {
      // the virtual robot against the robot as built: the twin runs on the nominal
      // description (no calibration here: docs/workcell.md), so this is the build's own error
      (void)arm.db->flush();
      const ToolErrorStats st = virtual_vs_truth(*arm.db, arm.model, arm.run, *arm.truth,
                                                 sort_from_us, sort_to_us, nullptr);
      if (st.count > 0) {
        say(fmt::format(
            "  {}: virtual -> true tool mean {:.2f} mm, p95 {:.2f} mm, max {:.2f} mm ({} "
            "samples; as built, seed {})",
            arm.name, m_to_mm(st.mean_m), m_to_mm(st.p95_m), m_to_mm(st.max_m), st.count,
            arm.build_seed));
        hub.record_metric(metric::kVirtTrueMeanMm, m_to_mm(st.mean_m), "mm");
        hub.record_metric(metric::kVirtTrueMaxMm, m_to_mm(st.max_m), "mm");
        rj["as_built_seed"] = arm.build_seed;
        rj["virtual_true_tool_mean_mm"] = m_to_mm(st.mean_m);
        rj["virtual_true_tool_p95_mm"] = m_to_mm(st.p95_m);
        rj["virtual_true_tool_max_mm"] = m_to_mm(st.max_m);
        rj["virtual_true_samples"] = st.count;
      }
    }
    j["robots"].push_back(rj);
    if (auto lat = arm.db->latencies(arm.run); lat) {
      const LatencyFigures lf = latency_figures(*lat, state_report_wire_s(transport::kDefaultBaud));
      hub.record_metric(metric::kFrames, static_cast<double>(lf.device_to_sim_ms.count), "frames");
      hub.record_metric(metric::kLatencyMeanMs, lf.device_to_sim_ms.mean, "ms");
      hub.record_metric(metric::kLatencyP99Ms, lf.device_to_sim_ms.p99, "ms");
      hub.record_metric(metric::kHubToSimMeanMs, lf.hub_to_sim_ms.mean, "ms");
    }
    hub.record_metric(metric::kLostFrames, static_cast<double>(mc.lost), "frames");
    hub.record_metric(metric::kDesyncAlarms, hub.desync_alarms(), "alarms");
    if (in_trays >= 0) hub.record_metric(metric::kCubesInTray, in_trays, "cubes");
  }
  if (touched) {
    say(fmt::format(
        "  the simulator saw robots {} and {} touch at {:.2f} s: every robot was stopped",
        touch.robot_a, touch.robot_b, touch.t_us * 1e-6));
  } else {
    say(fmt::format("  the arms never touched in the simulator"));
  }
  const bool ok = ran.ok() && in_trays == a.cubes && touches == 0 && lossless;
  {
    std::ofstream f(out / "results.json");
    f << j.dump(2) << "\n";
  }
  say(fmt::format("results: {}", (out / "results.json").string()));
  for (Arm& arm : arms) {
    (void)arm.hub->end_run(ok);
    const fs::path report = out / fmt::format("report-{}.html", arm.name);
    if (Status s = write_report(*arm.db, arm.model, arm.run, report); !s) {
      warn("report of " + arm.name + ": " + s.error().message);
    } else {
      say(fmt::format("report of {}: {}", arm.name, report.string()));
    }
  }
  if (!ran) warn(ran.error().message);
  say(fmt::format("demo {} in {:.0f} s: {} of {} cubes in their trays, {} robots",
                  ok ? "passed" : "FAILED", dur, std::max(in_trays, 0), a.cubes, n));
  if (a.before_stop) a.before_stop();
  for (Arm& arm : arms) arm.hub.reset();
  sim->stop();
  return CellDemoResult{ok};
}

}  // namespace scaratwin::session
