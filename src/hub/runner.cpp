#include "scaratwin/hub/runner.hpp"

#include <fstream>

#include <fmt/format.h>

#include "scaratwin/core/units.hpp"
#include "scaratwin/hub/tasks.hpp"

namespace scaratwin {
namespace {

std::string describe(const ControlFigures& f) {
  return fmt::format(
      "tool at ({:.4f}, {:.4f}, {:.4f}) m; error to target {:.3f} mm (physical), "
      "{:.3f} mm (virtual)",
      f.physical.x_m, f.physical.y_m, f.physical.z_m, m_to_mm(f.target_physical_m),
      m_to_mm(f.target_virtual_m));
}

Result<std::string> run_planned(Hub& hub, Result<JointTrajectory> traj) {
  if (!traj) return traj.error();
  auto n = hub.run_trajectory(*traj);
  if (!n) return n.error();
  return fmt::format("{} points, {:.2f} s", *n, traj->duration_s());
}

Result<std::string> execute_one(Hub& hub, const Statement& st) {
  const RobotModel& model = hub.model();
  const auto& v = st.numbers;
  switch (st.kind) {
    case StatementKind::kStop: {
      if (Status s = hub.stop(); !s) return s.error();
      return std::string("stopped (halted until the next home or motion)");
    }
    case StatementKind::kHome: {
      if (Status s = hub.home(); !s) return s.error();
      return std::string("homed");
    }
    case StatementKind::kMove: {
      auto f = st.has_yaw ? move_to(hub, {v[0], v[1], v[2], v[3]})
                          : move_to_position(hub, v[0], v[1], v[2]);
      if (!f) return f.error();
      return describe(*f);
    }
    case StatementKind::kLine: {
      auto now = hub.motion_start();
      if (!now) return now.error();
      const double yaw = st.has_yaw ? v[3] : forward(model, now->q).yaw_rad;
      return run_planned(hub, plan_line(model, now->q, {v[0], v[1], v[2], yaw}));
    }
    case StatementKind::kMoveJoints: {
      auto now = hub.motion_start();
      if (!now) return now.error();
      return run_planned(hub, plan_quintic(model, now->q, {v[0], v[1], v[2], v[3]}));
    }
    case StatementKind::kGrip:
    case StatementKind::kRelease: {
      const bool close = st.kind == StatementKind::kGrip;
      if (Status s = hub.set_gripper(close); !s) return s.error();
      // give the servo and the mirror time to follow.
      if (Status s = hub.sleep(0.4); !s) return s.error();
      return std::string(close ? "gripper closed" : "gripper open");
    }
    case StatementKind::kShoot: {
      auto png = hub.shoot();
      if (!png) return png.error();
      if (!st.text.empty()) {
        std::ofstream out(st.text, std::ios::binary);
        out.write(png->data(), static_cast<std::streamsize>(png->size()));
        if (!out)
          return Error{ScriptError::kWriteFailed, fmt::format("cannot write '{}'", st.text)};
        return fmt::format("{} bytes of PNG saved to {}", png->size(), st.text);
      }
      return fmt::format("{} bytes of PNG", png->size());
    }
    case StatementKind::kSpawn: {
      auto id = hub.spawn_cube(*parse_color(st.text), v[0], v[1]);
      if (!id) return id.error();
      return fmt::format("cube {} ({})", *id, st.text);
    }
    case StatementKind::kReset: {
      if (Status s = hub.reset_scene(); !s) return s.error();
      return std::string("scene reset");
    }
    case StatementKind::kPick: {
      auto objs = hub.objects();
      if (!objs) return objs.error();
      for (const protocol::ObjectPose& o : *objs) {
        if (o.id != static_cast<int>(v[0])) continue;
        auto now = hub.motion_start();
        if (!now) return now.error();
        auto plan = plan_sorting(model, now->q, {{o.color, o.x_m, o.y_m, o.yaw_rad}});
        if (!plan) return plan.error();
        return run_planned(hub, plan->trajectory);
      }
      return Error{ScriptError::kNoSuchCube,
                   fmt::format("no cube {} in the scene", static_cast<int>(v[0]))};
    }
    case StatementKind::kSort: {
      auto items = recognise_cubes(hub, model);
      if (!items) return items.error();
      auto now = hub.motion_start();
      if (!now) return now.error();
      auto plan = plan_sorting(model, now->q, *items);
      if (!plan) return plan.error();
      auto r = run_planned(hub, plan->trajectory);
      if (!r) return r.error();
      return fmt::format("{} cubes: {}", items->size(), *r);
    }
    case StatementKind::kWait:
      if (Status s = hub.sleep(v[0]); !s) return s.error();
      return fmt::format("waited {} s", v[0]);
    case StatementKind::kMirror: {
      hub.set_mirror(true);
      const MirrorCounters before = hub.mirror_counters();
      if (Status s = hub.sleep(v[0]); !s) return s.error();
      const MirrorCounters after = hub.mirror_counters();
      // lost: the robot's reports that never reached the hub, and the frames the simulator
      // never applied (its link lost, a refusal); a link that dropped is said, even when it
      // came back at once
      const std::uint64_t gaps = after.lost - before.lost;
      const std::uint64_t unapplied = after.not_applied - before.not_applied;
      const std::uint64_t drops = after.sim_link_losses - before.sim_link_losses;
      std::string text = fmt::format("{} frames mirrored, {} lost", after.applied - before.applied,
                                     gaps + unapplied);
      if (gaps + unapplied > 0) {
        text += fmt::format(" ({} robot reports missing, {} frames not applied by the simulator)",
                            gaps, unapplied);
      }
      text += fmt::format(", mean latency {:.2f} ms", after.mean_latency_ms);
      if (drops > 0) {
        text += fmt::format("; interrupted: the simulator link was lost {} time{}{}", drops,
                            drops == 1 ? "" : "s",
                            hub.sim_connected() ? " and came back" : " and is still down");
      }
      return text;
    }
  }
  return Error{ScriptError::kUnknownStatement, "unknown statement"};
}

}  // namespace

namespace {

// Runs one statement; on failure the error is prefixed with `where` ("line 3" or "a.txt:3").
Status execute_at(Hub& hub, const Statement& st, const StatementLog& log,
                  const std::string& where) {
  hub.record_event("statement", st.source);
  auto r = execute_one(hub, st);
  if (!r) {
    hub.record_event("error", r.error().message);
    return Error{r.error().code,
                 where.empty() ? fmt::format("{}: {}", st.source, r.error().message)
                               : fmt::format("{}: {}: {}", where, st.source, r.error().message)};
  }
  if (log) log(st, *r);
  return Ok{};
}

}  // namespace

Status execute(Hub& hub, const Statement& st, const StatementLog& log) {
  return execute_at(hub, st, log, st.line > 0 ? fmt::format("line {}", st.line) : "");
}

Status run_script(Hub& hub, const std::vector<Statement>& script, const std::string& name,
                  const StatementLog& log) {
  for (const Statement& st : script) {
    if (Status s = execute_at(hub, st, log, fmt::format("{}:{}", name, st.line)); !s) return s;
  }
  return Ok{};
}

}  // namespace scaratwin
