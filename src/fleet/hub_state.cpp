#include "scaratwin/fleet/hub_state.hpp"

#include <algorithm>
#include <chrono>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "scaratwin/core/units.hpp"
#include "scaratwin/fleet/topics.hpp"
#include "scaratwin/hub/runner.hpp"
#include "scaratwin/hub/script.hpp"
#include "scaratwin/kinematics/kinematics.hpp"

namespace scaratwin::fleet {

std::string robot_mode(const PhysicalState& ps) {
  namespace f = protocol::state_flags;
  const std::uint32_t flags = ps.raw.flags;
  if (!ps.valid) return "no-report";
  if (flags & f::kHalted) return "halted";
  if (flags & f::kHold) return "hold";
  if (flags & f::kTrajectory) return "trajectory";
  if (flags & f::kMoving) return "moving";
  if (!(flags & f::kHomed)) return "not-homed";
  return "idle";
}

std::string hub_state_json(const Hub& hub, std::string_view robot, std::uint64_t seq,
                           const JobStatus& job) {
  using nlohmann::json;
  const PhysicalState ps = hub.physical();
  const MirrorCounters mc = hub.mirror_counters();
  const transport::LinkCounters serial = hub.serial_counters();
  const auto now = std::chrono::system_clock::now().time_since_epoch();
  const std::int64_t steady_us = std::chrono::duration_cast<std::chrono::microseconds>(
                                     std::chrono::steady_clock::now().time_since_epoch())
                                     .count();
  const double report_age_ms =
      ps.valid ? static_cast<double>(steady_us - ps.rx_steady_us) / 1000.0 : -1.0;
  json j;
  j["robot"] = std::string(robot);
  j["seq"] = seq;
  j["t_ms"] = std::chrono::duration_cast<std::chrono::milliseconds>(now).count();
  j["mode"] = robot_mode(ps);
  j["flags"] = ps.raw.flags;
  if (ps.valid) {
    const ToolPose tool = forward(hub.model(), ps.q);
    j["joints"] = {{"d1_m", ps.q[0]},
                   {"q2_deg", rad_to_deg(ps.q[1])},
                   {"q3_deg", rad_to_deg(ps.q[2])},
                   {"q4_deg", rad_to_deg(ps.q[3])}};
    j["tool"] = {{"x_m", tool.x_m},
                 {"y_m", tool.y_m},
                 {"z_m", tool.z_m},
                 {"yaw_deg", rad_to_deg(tool.yaw_rad)}};
    j["steps"] = {ps.raw.steps[0], ps.raw.steps[1], ps.raw.steps[2]};
    j["grip_deg"] = ps.grip_deg;
  } else {
    j["joints"] = nullptr;
    j["tool"] = nullptr;
  }
  // a robot that has not reported for half a second is not heard (it reports at 100 Hz)
  j["link"] = {{"robot", ps.valid && report_age_ms < 500.0},
               {"robot_report_age_ms", report_age_ms},
               {"robot_errors", serial.errors},
               {"sim", hub.sim_connected()}};
  j["mirror"] = {{"frames", mc.applied},
                 {"lost", mc.lost + mc.not_applied},
                 {"latency_ms", mc.last_latency_ms},
                 {"mean_latency_ms", mc.mean_latency_ms}};
  j["alarms"] = {{"desync", hub.desync_alarms()},
                 {"halted", (ps.raw.flags & protocol::state_flags::kHalted) != 0},
                 {"interrupted", hub.interrupted()}};
  j["job"] = {{"id", json::parse(job.id_json, nullptr, false).is_discarded()
                         ? json(nullptr)
                         : json::parse(job.id_json, nullptr, false)},
              {"statement", job.statement},
              {"running", job.running},
              {"elapsed_s", job.elapsed_s},
              {"queued", job.queued},
              {"done", job.done},
              {"failed", job.failed}};
  return j.dump();
}

Result<std::string> run_statement_text(Hub& hub, std::string_view text) {
  auto st = parse_statement(text, 0);
  if (!st) return st.error();
  if (st->kind == StatementKind::kShoot && !st->text.empty()) {
    return Error{kMalformed, fmt::format("{}: over MQTT a picture is not saved on the hub's "
                                         "machine: send 'shoot' alone",
                                         st->source)};
  }
  std::string result;
  Status s = execute(hub, *st, [&](const Statement&, const std::string& r) { result = r; });
  if (!s) return s.error();
  return result;
}

StatePublisher::StatePublisher(MqttBridge& bridge, const Hub& hub, std::string robot,
                               double rate_hz, std::function<JobStatus()> job) {
  const auto period = std::chrono::duration_cast<std::chrono::steady_clock::duration>(
      std::chrono::duration<double>(1.0 / rate_hz));
  thread_ =
      std::thread([this, &bridge, &hub, robot = std::move(robot), period, job = std::move(job)] {
        std::uint64_t seq = 0;
        auto next = std::chrono::steady_clock::now();
        while (!stop_) {
          bridge.publish_state(hub_state_json(hub, robot, seq++, job ? job() : JobStatus{}));
          next += period;
          // short sleeps: the destructor never waits a whole period
          while (!stop_ && std::chrono::steady_clock::now() < next) {
            std::this_thread::sleep_for(std::min<std::chrono::steady_clock::duration>(
                next - std::chrono::steady_clock::now(), std::chrono::milliseconds(50)));
          }
        }
      });
}

StatePublisher::~StatePublisher() {
  stop_ = true;
  thread_.join();
}

}  // namespace scaratwin::fleet
