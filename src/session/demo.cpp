#include "scaratwin/session/demo.hpp"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <random>
#include <thread>
#include <utility>
#include <vector>

#include <fmt/format.h>

#include "scaratwin/config/robot_config.hpp"
#include "scaratwin/core/units.hpp"
#include "scaratwin/fleet/hub_state.hpp"
#include "scaratwin/fleet/mqtt_bridge.hpp"
#include "scaratwin/fleet/topics.hpp"
#include "scaratwin/hub/analysis.hpp"
#include "scaratwin/hub/report.hpp"
#include "scaratwin/hub/tasks.hpp"
#include "scaratwin/session/calibration.hpp"
#include "scaratwin/session/rig.hpp"
#include "scaratwin/session/ticker.hpp"
#include "scaratwin/transport/serial.hpp"
#include "scaratwin/vision/webcam.hpp"
#include "stop_watch.hpp"

namespace scaratwin::session {
namespace {

using namespace std::chrono_literals;

void step(const Say& say, int n, int total, const std::string& what) {
  say(fmt::format("==> [{}/{}] {}", n, total, what));
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

}  // namespace

Result<DemoOutcome> run_demo_phases(Hub& hub, TwinDb& db, const DemoPhaseOptions& a,
                                    std::int64_t demo, const Instruments& inst, const Say& say) {
  EmulatorSide* buttons = inst.side;
  std::vector<double> along_m;  // virtual -> true tool distances of every motion
  const RobotModel& model = hub.model();
  DemoOutcome out;
  constexpr int kSteps = 5;

  // 1. home
  step(say, 1, kSteps, "home the physical robot against its endstops");
  {
    auto run = hub.begin_run("home", "homing", demo);
    if (!run) return run.error();
    if (Status s = hub.set_twin_phase(protocol::TwinPhase::kMirror); !s) return s.error();
    hub.set_mirror(true);
    Ticker t(hub, "home", say);
    Status s = hub.home();
    (void)hub.end_run(s.ok());
    if (!s) return s.error();
  }

  // calibration: the twin measures the robot it is connected to and takes the calibrated
  // description for everything that follows
  const bool calibrating = a.calibrate && inst.side && inst.truth && inst.camera;
  if (calibrating) {
    say(fmt::format("==> [1+] calibration: the twin measures the robot as built and learns it"));
    auto run = hub.begin_run("calibration", "endstops, pattern, markers, touch-offs", demo);
    if (!run) return run.error();
    Ticker t(hub, "calibrate", say);
    auto cf = calibration_phase(hub, *inst.side, *inst.camera, a.base_config,
                                a.out_dir / "scara.calibrated.toml", a.seed + 1000, say);
    (void)hub.end_run(cf.ok());
    if (!cf) return cf.error();
    out.calibration = std::move(*cf);
  }

  // 2. mirror: the robot is moved by hand (its jog buttons; on a real board, which we cannot
  // reach, jog commands), the virtual robot follows it.
  step(say, 2, kSteps,
       buttons ? "digital mirror: press the robot's jog buttons, the virtual robot follows"
               : "digital mirror: jog the robot, the virtual robot follows");
  {
    auto run =
        hub.begin_run("mirror", buttons ? "three jog-button presses" : "three jog motions", demo);
    if (!run) return run.error();
    const MirrorCounters before = hub.mirror_counters();
    Ticker t(hub, "mirror", say);
    const std::pair<protocol::Axis, double> jogs[] = {
        {protocol::Axis::kJ2, 250.0}, {protocol::Axis::kJ3, -400.0}, {protocol::Axis::kZ, -3000.0}};
    const std::pair<const char*, int> presses[] = {{"j2+", 500}, {"j3-", 600}, {"z-", 900}};
    for (int i = 0; i < 3; ++i) {
      if (buttons) {
        say(fmt::format("    pressing the {} button for {} ms", presses[i].first,
                        presses[i].second));
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
      say(
          fmt::format("    mirror: {} frames, {} lost, latency robot->virtual mean {:.2f} ms, p99 "
                      "{:.2f} ms (paper: 74 ms)",
                      lf.device_to_sim_ms.count, after.lost - before.lost, lf.device_to_sim_ms.mean,
                      lf.device_to_sim_ms.p99));
    }
    (void)hub.end_run(true);
  }

  // 3. control: cubes spawned in the virtual scene are the targets of the physical robot, at
  // the paper's three control experiments.
  step(say, 3, kSteps,
       "digital control: spawn a cube, move the physical robot to it (three targets)");
  {
    auto run = hub.begin_run("control", "to three spawned cubes", demo);
    if (!run) return run.error();
    if (Status s = hub.set_twin_phase(protocol::TwinPhase::kControl); !s) return s.error();
    Ticker t(hub, "control", say);
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
      say(fmt::format(
          "    control {}: target ({:.1f}, {:.1f}) mm, {} points; target->reported {:.3f} mm, "
          "target->virtual {:.3f} mm{} (paper: {})",
          k + 1, m_to_mm(f->target.x_m), m_to_mm(f->target.y_m), f->points,
          m_to_mm(f->target_physical_m), m_to_mm(f->target_virtual_m), truth_text,
          std::array<const char*, 3>{"2.01 mm", "3.83 mm", "2.94 mm"}[k]));
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
  step(say, 4, kSteps, "digital prediction: camera shot, colour recognition, sorting simulated");
  std::vector<SortItem> layout = cube_layout(a.seed, a.cubes);
  if (a.layout_seed >= 0) {
    // spots the arm, where the control phase left it, would hide from the cameras are left out
    auto r =
        random_layout(model, static_cast<std::uint64_t>(a.layout_seed), a.cubes, hub.physical().q);
    if (!r) return r.error();
    layout = std::move(*r);
    say(fmt::format("    layout seed {}: cubes at random spots of the workspace", a.layout_seed));
  }
  std::vector<SortItem> where = layout;  // where the virtual twins of the cubes go
  SortPlan plan;
  std::int64_t prediction = 0;
  {
    auto run = hub.begin_run("prediction", "colour sorting in the simulator", demo);
    if (!run) return run.error();
    if (Status s = hub.set_twin_phase(protocol::TwinPhase::kPrediction); !s) return s.error();
    prediction = *run;
    Ticker t(hub, "predict", say);
    hub.set_mirror(false);
    std::this_thread::sleep_for(100ms);
    if (Status s = hub.reset_scene(); !s) return s.error();
    if (Status s = hub.sim_mode(protocol::SimMode::kSimulate); !s) return s.error();
    if (inst.side != nullptr) {
      // the operator puts the physical cubes where the layout says
      if (Status s = inst.side->clear(); !s) return s.error();
      for (const SortItem& it : layout) {
        if (Status s = inst.side->place(it.color, it.x_m, it.y_m); !s) return s.error();
        say(fmt::format("    operator: {} cube put on the table at ({:.1f}, {:.1f}) mm",
                        color_name(it.color), m_to_mm(it.x_m), m_to_mm(it.y_m)));
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
          say(fmt::format(
              "    robot's webcam: a smaller {} blob at ({:.1f}, {:.1f}) mm, {} px, left "
              "out (one cube of each colour is on the table)",
              color_name(d.color), m_to_mm(d.x_m), m_to_mm(d.y_m), d.area_px));
          continue;
        }
        have[static_cast<int>(d.color)] = true;
        where.push_back(SortItem{d.color, d.x_m, d.y_m, 0.0});
        say(fmt::format("    robot's webcam: {} cube at ({:.1f}, {:.1f}) mm", color_name(d.color),
                        m_to_mm(d.x_m), m_to_mm(d.y_m)));
      }
      if (where.size() != layout.size()) {
        return Error{AppError::kDemoRecognition,
                     fmt::format("the robot's webcam found {} cubes on the table, expected {}",
                                 where.size(), layout.size())};
      }
    }
    if (Status s = spawn_all(hub, where); !s) return s.error();
    for (const SortItem& it : where) {
      say(fmt::format("    spawned: virtual {} cube at ({:.1f}, {:.1f}) mm", color_name(it.color),
                      m_to_mm(it.x_m), m_to_mm(it.y_m)));
    }
    auto seen = recognise_cubes(hub, model);
    if (!seen) return seen.error();
    for (const SortItem& it : *seen) {
      say(fmt::format("    camera: {} cube at ({:.1f}, {:.1f}) mm", color_name(it.color),
                      m_to_mm(it.x_m), m_to_mm(it.y_m)));
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
    say(fmt::format("    plan: {} samples, {:.1f} s, {} gripper events",
                    plan.trajectory.samples.size(), plan.trajectory.duration_s(),
                    plan.trajectory.events.size()));
    if (Status s = hub.simulate_trajectory(plan.trajectory); !s) return s.error();
    std::this_thread::sleep_for(500ms);
    auto objs = hub.objects();
    if (!objs) return objs.error();
    out.in_trays_prediction = cubes_in_trays(model, *objs);
    hub.record_metric("prediction_cubes_in_tray", out.in_trays_prediction, "cubes");
    say(fmt::format("    prediction: {} of {} cubes in their trays", out.in_trays_prediction,
                    layout.size()));
    (void)hub.end_run(out.in_trays_prediction == static_cast<int>(layout.size()));
    if (out.in_trays_prediction != static_cast<int>(layout.size())) {
      return Error{AppError::kDemoPrediction,
                   "the prediction did not sort every cube: the plan is not replayed"};
    }
  }

  // 5. replay: the validated plan on the physical robot, mirrored live.
  step(say, 5, kSteps, "replay the validated plan on the physical robot");
  {
    auto run = hub.begin_run("replay", "colour sorting on the robot", demo, prediction);
    if (!run) return run.error();
    Ticker t(hub, "replay", say);
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
    say(fmt::format(
        "    replay: {:.1f} s on the robot, {:.1f} s per cube (the plan: {:.1f} s per cube)",
        replay_s, replay_s / static_cast<double>(layout.size()),
        plan.trajectory.duration_s() / static_cast<double>(layout.size())));
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
        say(fmt::format(
            "    replay: virtual -> true tool mean {:.2f} mm, p95 {:.2f} mm, max {:.2f} mm "
            "({} samples)",
            m_to_mm(st.mean_m), m_to_mm(st.p95_m), m_to_mm(st.max_m), st.count));
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
      out.replay_rms_mm = m_to_mm(d.tool_rms_m);
      out.replay_max_mm = m_to_mm(d.tool_max_m);
      say(fmt::format(
          "    replay vs prediction: tool deviation max {:.2f} mm, RMS {:.2f} mm, final "
          "{:.3f} mm",
          m_to_mm(d.tool_max_m), m_to_mm(d.tool_rms_m), m_to_mm(d.tool_final_m)));
    }
    say(fmt::format(
        "    replay: {} of {} cubes in their trays in the virtual scene{}, {} desync alarms "
        "(robot at most {:.2f} mm off the planned path)",
        out.in_trays_replay, layout.size(),
        out.physical_in_trays >= 0
            ? fmt::format(", {} of {} on the physical table", out.physical_in_trays, layout.size())
            : std::string(),
        hub.desync_alarms(), m_to_mm(hub.off_plan_worst_m())));
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
    Ticker t(hub, "rehome", say);
    Status s = hub.home();
    const HomingCheck hc = hub.last_homing();
    if (s && hc.measured) {
      const int lost = std::abs(hc.offset_steps[0]) + std::abs(hc.offset_steps[1]) +
                       std::abs(hc.offset_steps[2]);
      hub.record_metric(metric::kLostSteps, lost, "steps");
      out.steps_lost_homing = hc.offset_steps;
      say(fmt::format(
          "    homing again: the switches found the counts off by Z {}, J2 {}, J3 {} steps "
          "(tool {:.2f} mm), {} desync alarms in all",
          hc.offset_steps[0], hc.offset_steps[1], hc.offset_steps[2], m_to_mm(hc.tool_m),
          hub.desync_alarms()));
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

Result<std::shared_ptr<void>> publish_on_fleet(const std::string& url, const std::string& name,
                                               const Hub& hub, const Say& say) {
  auto broker = fleet::parse_broker_url(url);
  if (!broker) return broker.error();
  fleet::BridgeOptions bo;
  bo.broker = *broker;
  bo.robot = name.empty() ? hub.model().name : name;
  bo.accept_commands = false;
  auto b = fleet::MqttBridge::start(bo, nullptr, say);
  if (!b) return b.error();
  struct DemoFleet {
    std::unique_ptr<fleet::MqttBridge> bridge;
    std::optional<fleet::StatePublisher> publisher;
  };
  auto f = std::make_shared<DemoFleet>();
  f->bridge = std::move(*b);
  f->publisher.emplace(*f->bridge, hub, bo.robot, 10.0, [] {
    fleet::JobStatus j;
    j.statement = "demo";
    j.running = true;
    return j;
  });
  return std::shared_ptr<void>(f);
}

Result<DemoResult> run_demo(const RobotModel& description, const DemoOptions& o, const Say& say,
                            const Say& warn) {
  namespace fs = std::filesystem;
  const fs::path& out = o.out_dir;
  RobotModel model = description;
  RigOptions ro;
  ro.config_path = o.config_path;
  ro.serial = o.serial;
  ro.http_port = o.http_port;
  ro.robot_speed = o.robot_speed;
  ro.mqtt = o.mqtt;
  ro.companion = o.companion;
  ro.bin_dir = o.bin_dir;
  if (o.as_built_seed >= 0) {
    ro.as_built_seed = static_cast<std::uint64_t>(o.as_built_seed);
    // the build the emulator draws (the report compares the calibration with it)
    model.physical.as_built.seed = static_cast<std::uint64_t>(o.as_built_seed);
  }
  auto rig_r = start_rig(ro, out, say);
  if (!rig_r) return rig_r.error();
  Rig& rig = *rig_r;
  struct StopRig {
    Rig& rig;
    ~StopRig() { rig.stop(); }
  } stop_rig{rig};

  DemoResult result;
  result.plant = rig.plant;
  result.database = out / "twin.db";
  auto db = TwinDb::open(result.database);
  if (!db) return db.error();
  HubOptions ho;
  ho.serial_device = rig.device;
  ho.sim_port = rig.sim_port;
  auto hub = Hub::connect(model, ho, db->get());
  if (!hub) return hub.error();
  if (o.stop != nullptr && o.stop->load()) {
    return Error{HubError::kInterrupted, "interrupted before the first phase"};
  }
  std::optional<StopWatch> watch;
  watch.emplace(o.stop, **hub);
  std::shared_ptr<void> fleet;
  if (!o.mqtt.empty()) {
    auto f = publish_on_fleet(o.mqtt, "", **hub, say);
    if (!f) return f.error();
    fleet = std::move(*f);
  }
  auto demo = (*db)->begin_run("demo", o.serial.empty() ? "emulated robot" : o.serial);
  if (!demo) return demo.error();
  result.demo_run = *demo;
  const auto t0 = std::chrono::steady_clock::now();
  DemoPhaseOptions phases = o.phases;
  phases.out_dir = out;
  if (phases.base_config.empty()) {
    phases.base_config =
        o.config_path.empty() ? default_robot_config_path().string() : o.config_path;
  }
  const Instruments inst{rig.side ? &*rig.side : nullptr, rig.truth.get(), rig.webcam.get()};
  auto outcome = run_demo_phases(**hub, **db, phases, *demo, inst, say);
  result.duration_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const auto cubes = static_cast<std::size_t>(o.phases.cubes);
  result.ok = outcome && physical_ok(*outcome, cubes);
  if (outcome) {
    result.results = out / "results.json";
    if (Status s = write_results(result.results, rig.plant, *outcome); !s) {
      warn(s.error().message);
      result.results.clear();
    } else {
      say(fmt::format("results: {}", result.results.string()));
    }
    result.cubes_in_trays =
        outcome->physical_in_trays >= 0 ? outcome->physical_in_trays : outcome->in_trays_replay;
    result.outcome = std::move(*outcome);
  } else {
    result.failure = outcome.error();
  }
  (void)(*db)->end_run(*demo, result.ok ? "ok" : "failed", result.duration_s);
  if (result.failure) warn(result.failure->message);

  // report and exports, also after a failure: nothing recorded is lost.
  result.report = out / "report.html";
  if (Status s = write_report(**db, model, *demo, result.report); !s) {
    warn("report: " + s.error().message);
    result.report.clear();
  } else {
    say(fmt::format("report: {}", result.report.string()));
  }
  // one folder of CSV tables per run of the session.
  result.csv_dir = out / "csv";
  if (auto runs = (*db)->children(*demo); runs) {
    for (const RunInfo& r : *runs) {
      (void)(*db)->export_csv(r.id, result.csv_dir / fmt::format("{}-{}", r.id, r.kind));
    }
  }
  say(fmt::format("database: {} (run {}; `scaratwin report {} --db {}`), CSV in {}",
                  result.database.string(), *demo, *demo, result.database.string(),
                  result.csv_dir.string()));
  say(fmt::format(
      "demo {} in {:.0f} s: {} of {} cubes in their trays{}", result.ok ? "passed" : "FAILED",
      result.duration_s, result.cubes_in_trays, o.phases.cubes,
      result.outcome && result.outcome->physical_in_trays >= 0 ? " (the physical cubes)" : ""));
  if (o.before_stop) o.before_stop();
  watch.reset();
  fleet.reset();
  hub->reset();
  return result;
}

}  // namespace scaratwin::session
