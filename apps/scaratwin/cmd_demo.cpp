// scaratwin demo: the main job. Starts the simulator and the emulated robot (our firmware in
// simavr) as separate processes, connects the hub to both over real TCP and a pty, and runs the
// paper's three twin functions: mirror, control, and the colour-sorting prediction followed by
// its physical replay. Writes the database and the report; exits 0 only if every cube ends in
// its tray. `--serial /dev/ttyACM0` drives a real Arduino instead of the emulator.
#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <map>
#include <optional>
#include <random>
#include <thread>
#include <utility>

#include <fmt/format.h>

#include <nlohmann/json.hpp>

#include "calibrate_step.hpp"
#include "commands.hpp"
#include "demo_cell.hpp"
#include "demo_figures.hpp"
#include "demo_ticker.hpp"
#include "emulator_side.hpp"
#include "hub_session.hpp"
#include "rig.hpp"
#include "scaratwin/config/robot_config.hpp"
#include "scaratwin/core/units.hpp"
#include "scaratwin/fleet/local_broker.hpp"
#include "scaratwin/fleet/topics.hpp"
#include "scaratwin/hub/analysis.hpp"
#include "scaratwin/hub/hub.hpp"
#include "scaratwin/hub/process.hpp"
#include "scaratwin/hub/report.hpp"
#include "scaratwin/hub/tasks.hpp"
#include "scaratwin/hub/tool_tracker.hpp"
#include "scaratwin/transport/serial.hpp"
#include "scaratwin/vision/webcam.hpp"

namespace scaratwin::cli {
namespace {

using namespace std::chrono_literals;

struct DemoArgs {
  std::string serial;
  std::string out = "scaratwin-out";
  bool keep_open = false;
  int http_port = 8080;
  double robot_speed = 1.0;
  unsigned seed = 7;
  int cubes = kNumColors;  // cubes to sort: red, green, blue, the first `cubes` of them
  double mirror_s = 6.0;
  bool calibrate = true;
  long long as_built_seed = -1;  // the emulated robot's build (-1: the description's)
  std::string mqtt;              // publish the demo's state on this broker (docs/fleet.md)
  bool mqtt_given = false;       // --mqtt without a URL: start a Mosquitto of our own
  bool calibrate_given = false;  // --calibrate or --no-calibrate said
  long long layout_seed = -1;    // cubes at random spots of the workspace (-1: --seed's layout)
  int robots = 1;                // more: the robots of a workcell share the table (demo_cell.hpp)
  std::string workcell;          // their workcell file (default config/two_arms_trays.toml)
  // set by run_demo
  std::string base_config;
  std::filesystem::path out_dir;
};

std::atomic<bool> g_interrupted{false};
void on_interrupt(int) { g_interrupted = true; }

void step(int n, int total, const std::string& what) {
  fmt::print("==> [{}/{}] {}\n", n, total, what);
  std::fflush(stdout);
}

// Spawn positions for the cubes (one of each colour, in colour order, up to three): seeded,
// apart from each other, on the free side of the table (the trays are on the -y side).
std::vector<SortItem> cube_layout(unsigned seed, int cubes) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> x(0.14, 0.22), y(0.03, 0.12);
  std::vector<SortItem> out;
  for (int c = 0; c < cubes; ++c) {
    for (int tries = 0; tries < 1000; ++tries) {
      const SortItem it{static_cast<CubeColor>(c), x(rng), y(rng), 0.0};
      bool clear = true;
      for (const SortItem& o : out)
        clear = clear && std::hypot(o.x_m - it.x_m, o.y_m - it.y_m) > 0.045;
      if (clear) {
        out.push_back(it);
        break;
      }
    }
  }
  return out;
}

Status spawn_all(Hub& hub, const std::vector<SortItem>& items) {
  for (const SortItem& it : items) {
    auto id = hub.spawn_cube(it.color, it.x_m, it.y_m);
    if (!id) return id.error();
  }
  std::this_thread::sleep_for(300ms);  // let them settle
  return Ok{};
}

// The paper's three control experiments: the end-effector coordinates its physical robot
// reached (section 6), used here as the virtual targets.
constexpr std::array<std::array<double, 2>, 3> kControlTargets{
    {{0.2071, 0.0662}, {0.2422, -0.0421}, {0.1952, 0.0076}}};

// Measuring instruments of the emulated robot (none with a real board).
struct Instruments {
  EmulatorSide* side = nullptr;
  TruthRecorder* truth = nullptr;
  NetCamera* camera = nullptr;  // the robot's webcam (the twin's own sensor, not a truth)
};

Result<DemoOutcome> run_phases(Hub& hub, TwinDb& db, const DemoArgs& a, std::int64_t demo,
                               const Instruments& inst) {
  EmulatorSide* buttons = inst.side;
  std::vector<double> along_m;  // virtual -> true tool distances of every motion
  const RobotModel& model = hub.model();
  DemoOutcome out;
  constexpr int kSteps = 5;

  // 1. home
  step(1, kSteps, "home the physical robot against its endstops");
  {
    auto run = hub.begin_run("home", "homing", demo);
    if (!run) return run.error();
    if (Status s = hub.set_twin_phase(protocol::TwinPhase::kMirror); !s) return s.error();
    hub.set_mirror(true);
    Ticker t(hub, "home");
    Status s = hub.home();
    (void)hub.end_run(s.ok());
    if (!s) return s.error();
  }

  // calibration: the twin measures the robot it is connected to and takes the calibrated
  // description for everything that follows
  const bool calibrating = a.calibrate && inst.side && inst.truth && inst.camera;
  if (calibrating) {
    fmt::print("==> [1+] calibration: the twin measures the robot as built and learns it\n");
    auto run = hub.begin_run("calibration", "endstops, pattern, markers, touch-offs", demo);
    if (!run) return run.error();
    Ticker t(hub, "calibrate");
    auto cf = calibration_phase(hub, *inst.side, *inst.camera, a.base_config,
                                a.out_dir / "scara.calibrated.toml", a.seed + 1000);
    (void)hub.end_run(cf.ok());
    if (!cf) return cf.error();
    out.calibration = std::move(*cf);
  }

  // 2. mirror: the robot is moved by hand (its jog buttons; on a real board, which we cannot
  // reach, jog commands), the virtual robot follows it.
  step(2, kSteps,
       buttons ? "digital mirror: press the robot's jog buttons, the virtual robot follows"
               : "digital mirror: jog the robot, the virtual robot follows");
  {
    auto run =
        hub.begin_run("mirror", buttons ? "three jog-button presses" : "three jog motions", demo);
    if (!run) return run.error();
    const MirrorCounters before = hub.mirror_counters();
    Ticker t(hub, "mirror");
    const std::pair<protocol::Axis, double> jogs[] = {
        {protocol::Axis::kJ2, 250.0}, {protocol::Axis::kJ3, -400.0}, {protocol::Axis::kZ, -3000.0}};
    const std::pair<const char*, int> presses[] = {{"j2+", 500}, {"j3-", 600}, {"z-", 900}};
    for (int i = 0; i < 3; ++i) {
      if (buttons) {
        fmt::print("    pressing the {} button for {} ms\n", presses[i].first, presses[i].second);
        if (Status s = buttons->press(presses[i].first, presses[i].second); !s) return s.error();
      } else if (Status s = hub.jog(jogs[i].first, jogs[i].second); !s) {
        return s.error();
      }
      std::this_thread::sleep_for(std::chrono::duration<double>(a.mirror_s / 3));
    }
    if (Status s = hub.wait_idle(60.0); !s) return s.error();
    std::this_thread::sleep_for(200ms);
    const MirrorCounters after = hub.mirror_counters();
    out.lost_frames += after.lost - before.lost;
    auto lat = db.latencies(*run);
    if (lat) {
      const LatencyFigures lf = latency_figures(*lat, state_report_wire_s(transport::kDefaultBaud));
      out.latency = lf;
      hub.record_metric(metric::kFrames, static_cast<double>(lf.device_to_sim_ms.count), "frames");
      hub.record_metric(metric::kLatencyMeanMs, lf.device_to_sim_ms.mean, "ms");
      hub.record_metric(metric::kLatencyP99Ms, lf.device_to_sim_ms.p99, "ms");
      hub.record_metric(metric::kHubToSimMeanMs, lf.hub_to_sim_ms.mean, "ms");
      hub.record_metric(metric::kLostFrames, static_cast<double>(after.lost - before.lost),
                        "frames");
      fmt::print(
          "    mirror: {} frames, {} lost, latency robot->virtual mean {:.2f} ms, p99 "
          "{:.2f} ms (paper: 74 ms)\n",
          lf.device_to_sim_ms.count, after.lost - before.lost, lf.device_to_sim_ms.mean,
          lf.device_to_sim_ms.p99);
    }
    (void)hub.end_run(true);
  }

  // 3. control: cubes spawned in the virtual scene are the targets of the physical robot, at
  // the paper's three control experiments.
  step(3, kSteps, "digital control: spawn a cube, move the physical robot to it (three targets)");
  {
    auto run = hub.begin_run("control", "to three spawned cubes", demo);
    if (!run) return run.error();
    if (Status s = hub.set_twin_phase(protocol::TwinPhase::kControl); !s) return s.error();
    Ticker t(hub, "control");
    const std::uint64_t from_us = monotonic_us();
    double worst_virt_phys_mm = 0.0;
    for (std::size_t k = 0; k < kControlTargets.size(); ++k) {
      if (Status s = hub.reset_scene(); !s) return s.error();
      auto id = hub.spawn_cube(CubeColor::kRed, kControlTargets[k][0], kControlTargets[k][1]);
      if (!id) return id.error();
      std::this_thread::sleep_for(300ms);
      auto objs = hub.objects();
      if (!objs || objs->empty())
        return Error{AppError::kDemoNoCube, "control: the spawned cube is not in the scene"};
      const protocol::ObjectPose cube = objs->front();
      auto f = move_to_position(hub, cube.x_m, cube.y_m, model.scene.grasp_z_m + 0.005);
      if (!f) return f.error();
      hub.record_metric(metric::kToolErrTargetPhysMm, m_to_mm(f->target_physical_m), "mm");
      hub.record_metric(metric::kToolErrTargetVirtMm, m_to_mm(f->target_virtual_m), "mm");
      hub.record_metric(metric::kToolErrVirtPhysMm, m_to_mm(f->virtual_physical_m), "mm");
      worst_virt_phys_mm = std::max(worst_virt_phys_mm, m_to_mm(f->virtual_physical_m));
      std::string truth_text;
      if (inst.side != nullptr) {
        std::this_thread::sleep_for(200ms);  // let the arm settle on its belts
        auto tr = inst.side->query();
        if (tr && tr->as_built) {
          const double e = std::hypot(tr->tool[0] - f->target.x_m, tr->tool[1] - f->target.y_m,
                                      tr->tool[2] - f->target.z_m);
          out.control_error_mm.push_back(m_to_mm(e));
          hub.record_metric(metric::kControlErrTrueMm, m_to_mm(e), "mm");
          truth_text = fmt::format(", target->true tool {:.2f} mm", m_to_mm(e));
        }
      }
      fmt::print(
          "    control {}: target ({:.1f}, {:.1f}) mm, {} points; target->reported {:.3f} mm, "
          "target->virtual {:.3f} mm{} (paper: {})\n",
          k + 1, m_to_mm(f->target.x_m), m_to_mm(f->target.y_m), f->points,
          m_to_mm(f->target_physical_m), m_to_mm(f->target_virtual_m), truth_text,
          std::array<const char*, 3>{"2.01 mm", "3.83 mm", "2.94 mm"}[k]);
      // lift clear of the table before the next target.
      auto up = move_to_position(hub, cube.x_m, cube.y_m,
                                 model.scene.grasp_z_m + model.scene.approach_height_m,
                                 f->physical.yaw_rad);
      if (!up) return up.error();
    }
    out.virt_phys_mm = worst_virt_phys_mm;
    if (inst.truth != nullptr) {
      (void)db.flush();
      (void)virtual_vs_truth(db, model, *run, *inst.truth, from_us, monotonic_us(), &along_m);
    }
    (void)hub.end_run(true);
  }

  // 4. prediction: the sorting task in the simulator with physics.
  step(4, kSteps, "digital prediction: camera shot, colour recognition, sorting simulated");
  std::vector<SortItem> layout = cube_layout(a.seed, a.cubes);
  if (a.layout_seed >= 0) {
    // spots the arm, where the control phase left it, would hide from the cameras are left out
    auto r =
        random_layout(model, static_cast<std::uint64_t>(a.layout_seed), a.cubes, hub.physical().q);
    if (!r) return r.error();
    layout = std::move(*r);
    fmt::print("    layout seed {}: cubes at random spots of the workspace\n", a.layout_seed);
  }
  std::vector<SortItem> where = layout;  // where the virtual twins of the cubes go
  SortPlan plan;
  std::int64_t prediction = 0;
  {
    auto run = hub.begin_run("prediction", "colour sorting in the simulator", demo);
    if (!run) return run.error();
    if (Status s = hub.set_twin_phase(protocol::TwinPhase::kPrediction); !s) return s.error();
    prediction = *run;
    Ticker t(hub, "predict");
    hub.set_mirror(false);
    std::this_thread::sleep_for(100ms);
    if (Status s = hub.reset_scene(); !s) return s.error();
    if (Status s = hub.sim_mode(protocol::SimMode::kSimulate); !s) return s.error();
    if (inst.side != nullptr) {
      // the operator puts the physical cubes where the layout says
      if (Status s = inst.side->clear(); !s) return s.error();
      for (const SortItem& it : layout) {
        if (Status s = inst.side->place(it.color, it.x_m, it.y_m); !s) return s.error();
        fmt::print("    operator: {} cube put on the table at ({:.1f}, {:.1f}) mm\n",
                   color_name(it.color), m_to_mm(it.x_m), m_to_mm(it.y_m));
      }
    }
    if (inst.camera != nullptr) {
      // the twin finds the physical cubes in the robot's webcam and spawns their virtual
      // twins where it sees them
      std::this_thread::sleep_for(300ms);
      auto frame = inst.camera->grab(model.scene.camera.width_px, model.scene.camera.height_px);
      if (!frame) return frame.error();
      auto found = detect_cubes(frame->image, model);
      if (model.webcam.valid) {
        // the calibrated webcam: its pose and lens put each cube's centre on the table
        const WebcamModel cam = calib::from_description(model.webcam);
        for (CubeDetection& d : found) {
          std::array<double, 3> p{};
          if (unproject_to_plane(cam, d.col, d.row, frame->image.width, frame->image.height,
                                 model.scene.table_z_m + 0.5 * model.scene.cube_size_m, p)) {
            d.x_m = p[0];
            d.y_m = p[1];
          }
        }
      }
      where.clear();
      std::array<bool, kNumColors> have{};
      for (const CubeDetection& d : found) {
        // the operator put one cube of each colour: the largest blob of a colour is its cube
        // (detections come sorted by colour, then by area); a smaller one is a piece of it
        // (a side face the picture shows apart from the top) and is said, not spawned
        if (have[static_cast<int>(d.color)]) {
          fmt::print(
              "    robot's webcam: a smaller {} blob at ({:.1f}, {:.1f}) mm, {} px, left "
              "out (one cube of each colour is on the table)\n",
              color_name(d.color), m_to_mm(d.x_m), m_to_mm(d.y_m), d.area_px);
          continue;
        }
        have[static_cast<int>(d.color)] = true;
        where.push_back(SortItem{d.color, d.x_m, d.y_m, 0.0});
        fmt::print("    robot's webcam: {} cube at ({:.1f}, {:.1f}) mm\n", color_name(d.color),
                   m_to_mm(d.x_m), m_to_mm(d.y_m));
      }
      if (where.size() != layout.size()) {
        return Error{AppError::kDemoRecognition,
                     fmt::format("the robot's webcam found {} cubes on the table, expected {}",
                                 where.size(), layout.size())};
      }
    }
    if (Status s = spawn_all(hub, where); !s) return s.error();
    for (const SortItem& it : where) {
      fmt::print("    spawned: virtual {} cube at ({:.1f}, {:.1f}) mm\n", color_name(it.color),
                 m_to_mm(it.x_m), m_to_mm(it.y_m));
    }
    auto seen = recognise_cubes(hub, model);
    if (!seen) return seen.error();
    for (const SortItem& it : *seen) {
      fmt::print("    camera: {} cube at ({:.1f}, {:.1f}) mm\n", color_name(it.color),
                 m_to_mm(it.x_m), m_to_mm(it.y_m));
    }
    if (seen->size() != layout.size()) {
      return Error{AppError::kDemoRecognition,
                   fmt::format("colour recognition found {} cubes, expected {}", seen->size(),
                               layout.size())};
    }
    auto start = hub.fresh_physical(2.0);
    if (!start) return start.error();
    auto p = plan_sorting(model, start->q, *seen);
    if (!p) return p.error();
    plan = *p;
    fmt::print("    plan: {} samples, {:.1f} s, {} gripper events\n",
               plan.trajectory.samples.size(), plan.trajectory.duration_s(),
               plan.trajectory.events.size());
    if (Status s = hub.simulate_trajectory(plan.trajectory); !s) return s.error();
    std::this_thread::sleep_for(500ms);
    auto objs = hub.objects();
    if (!objs) return objs.error();
    out.in_trays_prediction = cubes_in_trays(model, *objs);
    hub.record_metric("prediction_cubes_in_tray", out.in_trays_prediction, "cubes");
    fmt::print("    prediction: {} of {} cubes in their trays\n", out.in_trays_prediction,
               layout.size());
    (void)hub.end_run(out.in_trays_prediction == static_cast<int>(layout.size()));
    if (out.in_trays_prediction != static_cast<int>(layout.size())) {
      return Error{AppError::kDemoPrediction,
                   "the prediction did not sort every cube: the plan is not replayed"};
    }
  }

  // 5. replay: the validated plan on the physical robot, mirrored live.
  step(5, kSteps, "replay the validated plan on the physical robot");
  {
    auto run = hub.begin_run("replay", "colour sorting on the robot", demo, prediction);
    if (!run) return run.error();
    Ticker t(hub, "replay");
    if (Status s = hub.sim_mode(protocol::SimMode::kMirror); !s) return s.error();
    if (Status s = hub.reset_scene(); !s) return s.error();
    if (Status s = spawn_all(hub, where); !s) return s.error();
    const MirrorCounters before = hub.mirror_counters();
    hub.set_mirror(true);
    const std::uint64_t replay_from_us = monotonic_us();
    auto n = hub.run_trajectory(plan.trajectory);
    if (!n) return n.error();
    const std::uint64_t replay_to_us = monotonic_us();
    const double replay_s = static_cast<double>(replay_to_us - replay_from_us) / 1e6;
    hub.record_metric("replay_s_per_cube", replay_s / static_cast<double>(layout.size()), "s");
    fmt::print(
        "    replay: {:.1f} s on the robot, {:.1f} s per cube (the plan: {:.1f} s per cube)\n",
        replay_s, replay_s / static_cast<double>(layout.size()),
        plan.trajectory.duration_s() / static_cast<double>(layout.size()));
    std::this_thread::sleep_for(700ms);
    const MirrorCounters after = hub.mirror_counters();
    out.lost_frames += after.lost - before.lost;
    auto objs = hub.objects();
    if (!objs) return objs.error();
    out.in_trays_replay = cubes_in_trays(model, *objs);
    hub.record_metric(metric::kCubesInTray, out.in_trays_replay, "cubes");
    if (inst.side != nullptr) {
      auto physical = inst.side->cubes();
      if (physical && !physical->empty()) {
        out.physical_in_trays = cubes_in_trays(model, *physical);
        hub.record_metric(metric::kPhysicalCubesInTray, out.physical_in_trays, "cubes");
      }
    }
    if (inst.truth != nullptr) {
      (void)db.flush();
      const ToolErrorStats st =
          virtual_vs_truth(db, model, *run, *inst.truth, replay_from_us, replay_to_us, &along_m);
      if (st.count > 0) {
        fmt::print(
            "    replay: virtual -> true tool mean {:.2f} mm, p95 {:.2f} mm, max {:.2f} mm "
            "({} samples)\n",
            m_to_mm(st.mean_m), m_to_mm(st.p95_m), m_to_mm(st.max_m), st.count);
      }
    }
    hub.record_metric(metric::kDesyncAlarms, hub.desync_alarms(), "alarms");
    hub.record_metric(metric::kOffPlanMaxMm, m_to_mm(hub.off_plan_worst_m()), "mm");
    hub.record_metric(metric::kReplayLostFrames, static_cast<double>(after.lost - before.lost),
                      "frames");
    auto pred = db.samples(prediction, SampleSource::kVirtual);
    auto phys = db.samples(*run, SampleSource::kPhysical);
    if (pred && phys && !pred->empty() && !phys->empty()) {
      // at equal progress along the predicted path: the robot's clock and the simulator's
      // differ, only where the robots went counts
      const Deviation d = compare_runs_by_progress(model, as_plan(*pred), *pred, *phys);
      hub.record_metric(metric::kReplayToolMaxMm, m_to_mm(d.tool_max_m), "mm");
      hub.record_metric(metric::kReplayToolRmsMm, m_to_mm(d.tool_rms_m), "mm");
      hub.record_metric(metric::kReplayFinalMm, m_to_mm(d.tool_final_m), "mm");
      fmt::print(
          "    replay vs prediction: tool deviation max {:.2f} mm, RMS {:.2f} mm, final "
          "{:.3f} mm\n",
          m_to_mm(d.tool_max_m), m_to_mm(d.tool_rms_m), m_to_mm(d.tool_final_m));
    }
    fmt::print(
        "    replay: {} of {} cubes in their trays in the virtual scene{}, {} desync alarms "
        "(robot at most {:.2f} mm off the planned path)\n",
        out.in_trays_replay, layout.size(),
        out.physical_in_trays >= 0
            ? fmt::format(", {} of {} on the physical table", out.physical_in_trays, layout.size())
            : std::string(),
        hub.desync_alarms(), m_to_mm(hub.off_plan_worst_m()));
    (void)hub.end_run(physical_ok(out, layout.size()));
  }
  // the steps the motors really lost, before homing again hides them
  if (inst.side != nullptr) {
    auto tr = inst.side->query();
    if (tr && tr->as_built) out.steps_lost_truth = tr->lost;
  }
  // homing again: the robot has no encoders, but its switches show the steps its motors lost
  {
    auto run = hub.begin_run("rehome", "homing again: steps lost during the demo", demo);
    if (!run) return run.error();
    if (Status s = hub.set_twin_phase(protocol::TwinPhase::kMirror); !s) return s.error();
    Ticker t(hub, "rehome");
    Status s = hub.home();
    const HomingCheck hc = hub.last_homing();
    if (s && hc.measured) {
      const int lost = std::abs(hc.offset_steps[0]) + std::abs(hc.offset_steps[1]) +
                       std::abs(hc.offset_steps[2]);
      hub.record_metric(metric::kLostSteps, lost, "steps");
      out.steps_lost_homing = hc.offset_steps;
      fmt::print(
          "    homing again: the switches found the counts off by Z {}, J2 {}, J3 {} steps "
          "(tool {:.2f} mm), {} desync alarms in all\n",
          hc.offset_steps[0], hc.offset_steps[1], hc.offset_steps[2], m_to_mm(hc.tool_m),
          hub.desync_alarms());
    }
    (void)hub.end_run(s.ok() && hc.measured);
    if (!s) return s.error();
  }
  if (!along_m.empty()) {
    out.virt_phys_along = error_stats(along_m);
    (void)db.add_metric(demo, metric::kVirtTrueMeanMm, m_to_mm(out.virt_phys_along.mean_m), "mm");
    (void)db.add_metric(demo, metric::kVirtTrueMaxMm, m_to_mm(out.virt_phys_along.max_m), "mm");
  }
  if (out.steps_lost_truth) {
    const auto& l = *out.steps_lost_truth;
    (void)db.add_metric(demo, metric::kLostStepsTrue,
                        static_cast<double>(std::llabs(l[0]) + std::llabs(l[1]) + std::llabs(l[2])),
                        "steps");
  }
  return out;
}

int run_demo(const CommonOptions& common, const DemoArgs& a) {
  if (a.robots > 1 || !a.workcell.empty()) {
    if (!a.serial.empty() || a.calibrate_given || a.mqtt_given || a.layout_seed >= 0 ||
        !common.config_path.empty()) {
      std::fprintf(stderr,
                   "scaratwin demo: --robots/--workcell runs the workcell's emulated robots; "
                   "--serial, --calibrate, --mqtt, --layout-seed and --config are for the single "
                   "robot\n");
      return kExitUsage;
    }
    CellDemoOptions c;
    c.robots = a.robots;
    c.workcell = a.workcell;
    c.out = a.out;
    c.http_port = a.http_port;
    c.robot_speed = a.robot_speed;
    c.seed = a.seed;
    c.cubes = a.cubes;
    c.keep_open = a.keep_open;
    c.as_built_seed = a.as_built_seed;
    return run_cell_demo(c);
  }
  auto model = load_model(common);
  if (!model) return kExitUsage;
  namespace fs = std::filesystem;
  const auto out_dir = create_out_dir(a.out, "demo");
  if (!out_dir) return kExitUsage;
  const fs::path& out = *out_dir;
  // --mqtt with no URL: the demo starts its own broker (Mosquitto on a free loopback port)
  fleet::LocalBroker own_broker;
  std::string mqtt = a.mqtt;
  if (a.mqtt_given && mqtt.empty()) {
    auto b = fleet::start_local_broker(out / "broker");
    if (!b) {
      std::fprintf(stderr, "scaratwin demo: --mqtt: %s\n", b.error().message.c_str());
      return kExitFailure;
    }
    own_broker = std::move(*b);
    mqtt = own_broker.url;
    fmt::print("fleet broker: Mosquitto on {} (started by the demo; log in {})\n", mqtt,
               (out / "broker").string());
  }
  if (!mqtt.empty()) {
    if (auto b = fleet::parse_broker_url(mqtt); !b) {
      std::fprintf(stderr, "scaratwin demo: %s\n", b.error().message.c_str());
      return kExitUsage;
    }
  }
  std::signal(SIGINT, on_interrupt);
  std::signal(SIGTERM, on_interrupt);
  fmt::print("scaratwin demo: results in {}\n", out.string());

  RigOptions ro;
  ro.config_path = common.config_path;
  ro.serial = a.serial;
  ro.http_port = a.http_port;
  ro.robot_speed = a.robot_speed;
  ro.mqtt = mqtt;
  ro.companion = a.keep_open;  // the paper's own scripts may drive the scene left open
  if (a.as_built_seed >= 0) {
    ro.as_built_seed = static_cast<std::uint64_t>(a.as_built_seed);
    // the build the emulator draws (the report compares the calibration with it)
    model->physical.as_built.seed = static_cast<std::uint64_t>(a.as_built_seed);
  }
  auto rig_r = start_rig(ro, out);
  if (!rig_r) {
    std::fprintf(stderr, "scaratwin demo: %s\n", rig_r.error().message.c_str());
    return kExitFailure;
  }
  Rig& rig = *rig_r;
  const std::string plant = rig.plant;

  auto db = TwinDb::open(out / "twin.db");
  if (!db) {
    std::fprintf(stderr, "scaratwin demo: %s\n", db.error().message.c_str());
    return kExitFailure;
  }
  HubOptions ho;
  ho.serial_device = rig.device;
  ho.sim_port = rig.sim_port;
  auto hub = Hub::connect(*model, ho, db->get());
  if (!hub) {
    std::fprintf(stderr, "scaratwin demo: %s\n", hub.error().message.c_str());
    return kExitFailure;
  }
  std::shared_ptr<void> fleet;
  if (!mqtt.empty()) {
    auto f = start_demo_fleet(mqtt, "", **hub);
    if (!f) {
      std::fprintf(stderr, "scaratwin demo: %s\n", f.error().message.c_str());
      return kExitUsage;
    }
    fleet = std::move(*f);
  }
  auto demo = (*db)->begin_run("demo", a.serial.empty() ? "emulated robot" : a.serial);
  if (!demo) {
    std::fprintf(stderr, "scaratwin demo: %s\n", demo.error().message.c_str());
    return kExitFailure;
  }
  const auto t0 = std::chrono::steady_clock::now();
  DemoArgs args = a;
  args.out_dir = out;
  args.base_config =
      common.config_path.empty() ? default_robot_config_path().string() : common.config_path;
  const Instruments inst{rig.side ? &*rig.side : nullptr, rig.truth.get(), rig.webcam.get()};
  auto outcome = run_phases(**hub, **db, args, *demo, inst);
  const double dur = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const bool ok = outcome && physical_ok(*outcome, static_cast<std::size_t>(a.cubes));
  if (outcome) {
    if (Status s = write_results(out / "results.json", plant, *outcome); !s) {
      std::fprintf(stderr, "scaratwin demo: %s\n", s.error().message.c_str());
    } else {
      fmt::print("results: {}\n", (out / "results.json").string());
    }
  }
  (void)(*db)->end_run(*demo, ok ? "ok" : "failed", dur);
  if (!outcome) std::fprintf(stderr, "scaratwin demo: %s\n", outcome.error().message.c_str());

  // report and exports, also after a failure: nothing recorded is lost.
  const fs::path report = out / "report.html";
  if (Status s = write_report(**db, *model, *demo, report); !s) {
    std::fprintf(stderr, "scaratwin demo: report: %s\n", s.error().message.c_str());
  } else {
    fmt::print("report: {}\n", report.string());
  }
  // one folder of CSV tables per run of the session.
  if (auto runs = (*db)->children(*demo); runs) {
    for (const RunInfo& r : *runs) {
      (void)(*db)->export_csv(r.id, out / "csv" / fmt::format("{}-{}", r.id, r.kind));
    }
  }
  fmt::print("database: {} (run {}; `scaratwin report {} --db {}`), CSV in {}\n",
             (out / "twin.db").string(), *demo, *demo, (out / "twin.db").string(),
             (out / "csv").string());
  fmt::print("demo {} in {:.0f} s: {} of {} cubes in their trays{}\n", ok ? "passed" : "FAILED",
             dur,
             outcome ? (outcome->physical_in_trays >= 0 ? outcome->physical_in_trays
                                                        : outcome->in_trays_replay)
                     : 0,
             a.cubes, outcome && outcome->physical_in_trays >= 0 ? " (the physical cubes)" : "");
  std::fflush(stdout);
  if (a.keep_open) {
    fmt::print("--keep-open: the simulator and its UI keep running; Ctrl-C to stop\n");
    std::fflush(stdout);
    while (!g_interrupted) std::this_thread::sleep_for(200ms);
  }
  fleet.reset();
  hub->reset();
  rig.stop();
  return ok ? kExitOk : kExitFailure;
}

}  // namespace

void add_demo_command(CLI::App& app, CommonOptions& common, Runner& run) {
  auto a = std::make_shared<DemoArgs>();
  CLI::App* cmd = app.add_subcommand(
      "demo",
      "the whole twin, no hardware needed: simulator + emulated robot + hub; mirror, "
      "control, colour-sorting prediction and its physical replay; database and report");
  cmd->add_option("--serial", a->serial,
                  "drive a real Arduino on this serial port instead of the emulator "
                  "(e.g. /dev/ttyACM0)");
  cmd->add_option("--out", a->out, "folder for the database, report, CSV and logs")
      ->capture_default_str();
  cmd->add_flag("--keep-open", a->keep_open,
                "leave the simulator and its UI running at the end; the simulator also serves the "
                "paper's companion TCP dialect on 127.0.0.1 (its port printed at the start)");
  cmd->add_option("--http-port", a->http_port, "port of the browser UI (0: none)")
      ->capture_default_str();
  cmd->add_option("--robot-speed", a->robot_speed,
                  "emulated robot: emulated seconds per wall second (1 = real time)")
      ->capture_default_str();
  cmd->add_option("--seed", a->seed, "seed of the cube layout")->capture_default_str();
  cmd->add_option("--cubes", a->cubes,
                  "cubes to sort (red, then green, then blue); --cubes 1 is the short demo")
      ->check(CLI::Range(1, kNumColors))
      ->capture_default_str();
  CLI::Option* calibrate = cmd->add_flag(
      "--calibrate,!--no-calibrate", a->calibrate,
      "calibrate after homing (the default with the emulated robot as built): the twin "
      "measures the robot and runs on the calibrated description "
      "(docs/calibration.md); --no-calibrate runs on the description as it is");
  cmd->add_option(
         "--as-built-seed", a->as_built_seed,
         "emulated robot: the seed of its build (default: the description's; with --robots, "
         "robot i's build is drawn with this seed + i)")
      ->check(CLI::Range(0LL, 2147483647LL));
  cmd->add_option("--layout-seed", a->layout_seed,
                  "put the cubes at random reachable, non-overlapping spots of the workspace drawn "
                  "from this seed (default: --seed's spots on the free side of the table)")
      ->check(CLI::Range(0LL, 2147483647LL));
  cmd->add_option(
         "--robots", a->robots,
         "robots on the table: 2 runs the two emulated arms of config/two_arms_trays.toml (or "
         "--workcell), which sort the cubes together (docs/workcell.md)")
      ->check(CLI::Range(1, 8))
      ->capture_default_str();
  cmd->add_option("--workcell", a->workcell,
                  "the workcell file of --robots (its robots, base poses and scene)")
      ->check(CLI::ExistingFile);
  CLI::Option* mqtt =
      cmd->add_option("--mqtt", a->mqtt,
                      "publish the robot's state on this MQTT broker, "
                      "mqtt://[USER[:PASSWORD]@]HOST[:PORT], and show the fleet page "
                      "(/fleet.html); --mqtt alone starts a Mosquitto of the demo's own "
                      "(docs/fleet.md)")
          ->expected(0, 1);
  add_common_options(*cmd, common, false);
  cmd->callback([&common, &run, a, mqtt, calibrate] {
    a->mqtt_given = mqtt->count() > 0;
    a->calibrate_given = calibrate->count() > 0;
    run = [&common, a] { return run_demo(common, *a); };
  });
}

}  // namespace scaratwin::cli
