// The JSON messages of the browser feed and the page's commands.
#include "scaratwin/web/feed.hpp"

#include <array>
#include <cmath>
#include <numbers>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "scaratwin/sim/camera.hpp"
#include "scaratwin/sim/mjcf.hpp"
#include "scaratwin/vision/vision.hpp"

namespace scaratwin::web {
namespace {

using nlohmann::json;

constexpr double kRadToDeg = 180.0 / std::numbers::pi;
constexpr const char* kJointNames[kNumJoints] = {"d1", "q2", "q3", "q4"};

// rounding keeps the 30 Hz feed small: 10 um and 1e-5 of a quaternion are below what a screen
// shows
// (dividing by an exact power of ten gives the double nearest the decimal, so it prints short)
double round_to(double v, double step) {
  const double scale = std::round(1.0 / step);
  return std::round(v * scale) / scale;
}
double r5(double v) { return round_to(v, 1e-5); }

template <std::size_t N>
json vec(const std::array<double, N>& a) {
  json out = json::array();
  for (double v : a) out.push_back(r5(v));
  return out;
}

// joint i in display units: mm for the prismatic d1, degrees for the hinges
double display_value(int joint, double v) { return joint == 0 ? v * 1e3 : v * kRadToDeg; }
const char* display_unit(int joint) { return joint == 0 ? "mm" : "deg"; }

// A tool pose, m and rad.
json tool_json(const ToolPose& t) {
  return {{"x", r5(t.x_m)}, {"y", r5(t.y_m)}, {"z", r5(t.z_m)}, {"yaw", r5(t.yaw_rad)}};
}

json joints_json(const JointVector& q) {
  json out = json::array();
  for (int i = 0; i < kNumJoints; ++i) out.push_back(r5(q[i]));
  return out;
}
json display_json(const JointVector& q) {
  json out = json::array();
  for (int i = 0; i < kNumJoints; ++i) out.push_back(round_to(display_value(i, q[i]), 1e-3));
  return out;
}

json cube_json(const sim::CubeState& c) {
  return {{"id", c.id},
          {"color", color_name(c.color)},
          {"pos", vec(c.pos_m)},
          {"quat", vec(c.quat_wxyz)},
          {"held", c.held}};
}

std::string reply(const Command& command, bool ok, json extra = json::object()) {
  json out = {{"type", "reply"}, {"ok", ok}};
  if (command.id) out["id"] = *command.id;
  switch (command.kind) {
    case Command::Kind::kSpawn:
      out["cmd"] = "spawn";
      break;
    case Command::Kind::kReset:
      out["cmd"] = "reset";
      break;
    case Command::Kind::kShoot:
      out["cmd"] = "shoot";
      break;
    case Command::Kind::kPing:
      out["cmd"] = "ping";
      break;
  }
  out.update(extra);
  return out.dump();
}

std::string base64(const std::vector<std::uint8_t>& bytes) {
  static constexpr char kAlphabet[] =
      "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  out.reserve((bytes.size() + 2) / 3 * 4);
  std::size_t i = 0;
  for (; i + 2 < bytes.size(); i += 3) {
    const std::uint32_t v = (std::uint32_t{bytes[i]} << 16) | (std::uint32_t{bytes[i + 1]} << 8) |
                            std::uint32_t{bytes[i + 2]};
    out += kAlphabet[(v >> 18) & 63];
    out += kAlphabet[(v >> 12) & 63];
    out += kAlphabet[(v >> 6) & 63];
    out += kAlphabet[v & 63];
  }
  if (i < bytes.size()) {
    std::uint32_t v = std::uint32_t{bytes[i]} << 16;
    if (i + 1 < bytes.size()) v |= std::uint32_t{bytes[i + 1]} << 8;
    out += kAlphabet[(v >> 18) & 63];
    out += kAlphabet[(v >> 12) & 63];
    out += i + 1 < bytes.size() ? kAlphabet[(v >> 6) & 63] : '=';
    out += '=';
  }
  return out;
}

}  // namespace

std::string scene_message(const RobotModel& robot, const sim::SceneGeometry& geometry,
                          double feed_hz, bool fleet) {
  json joints = json::array();
  for (int i = 0; i < kNumJoints; ++i) {
    joints.push_back({{"name", kJointNames[i]},
                      {"unit", display_unit(i)},
                      {"min", robot.limits[i].min},
                      {"max", robot.limits[i].max},
                      {"min_display", display_value(i, robot.limits[i].min)},
                      {"max_display", display_value(i, robot.limits[i].max)},
                      {"home", robot.home[i]}});
  }
  json geoms = json::array();
  for (const sim::GeomShape& g : geometry.geoms) {
    geoms.push_back({{"type", g.type},
                     {"body", g.body},
                     {"size", vec(g.size)},
                     {"pos", vec(g.pos_m)},
                     {"quat", vec(g.quat_wxyz)},
                     {"rgba", {g.rgba[0], g.rgba[1], g.rgba[2], g.rgba[3]}}});
  }
  json trays = json::array();
  for (int c = 0; c < kNumColors; ++c) {
    const Tray& t = robot.scene.trays[c];
    trays.push_back(
        {{"color", color_name(CubeColor(c))}, {"x", t.x_m}, {"y", t.y_m}, {"size", t.size_m}});
  }
  const CameraModel& cam = robot.scene.camera;
  const CameraAxes axes = camera_axes(cam);
  json out = {{"type", "scene"},
              {"version", 1},
              {"robot", robot.name},
              {"feed_hz", feed_hz},
              {"fleet", fleet},
              {"joints", joints},
              {"bodies", geometry.bodies},
              {"geoms", geoms},
              {"trays", trays},
              {"table_z", robot.scene.table_z_m},
              {"cube_size", robot.scene.cube_size_m},
              {"grasp_z", robot.scene.grasp_z_m},
              {"camera",
               {{"name", geometry.camera_name},
                {"pos", vec(cam.pos_m)},
                {"look_at", vec(cam.look_at_m)},
                {"fovy_deg", cam.fovy_deg},
                {"width_px", cam.width_px},
                {"height_px", cam.height_px},
                {"x", vec(axes.x)},
                {"y", vec(axes.y)},
                {"z", vec(axes.z)}}}};
  return out.dump();
}

namespace {
// A link's figures: connected, frames, lost, rate, and the latencies once a frame came.
json link_figures(const LinkStatus& link) {
  json j = {{"connected", link.connected},
            {"frames", link.frames},
            {"lost", link.lost},
            {"rate_hz", round_to(link.frame_rate_hz, 0.1)}};
  if (link.has_latency) {
    j["latency_ms"] = round_to(link.latency_last_s * 1e3, 1e-3);
    j["latency_mean_ms"] = round_to(link.latency_mean_s * 1e3, 1e-3);
    j["latency_max_ms"] = round_to(link.latency_max_s * 1e3, 1e-3);
  }
  return j;
}
}  // namespace

std::string twin_mode(const sim::Snapshot& snapshot, const LinkStatus& link, double world_speed) {
  if (!link.twin_mode.empty()) return link.twin_mode;
  if (snapshot.mode == sim::Mode::kMirror) return "mirror";
  return world_speed == 0.0 ? "prediction" : "control";
}

std::string state_message(const RobotModel& robot, const sim::Snapshot& s, const LinkStatus& link,
                          const StateExtras& extras) {
  json out_of_limit = json::array();
  for (int i = 0; i < kNumJoints; ++i) {
    // a hair of tolerance (1 um, 1 urad): a joint parked on its limit is not out of it
    constexpr double tol = 1e-6;
    out_of_limit.push_back(s.joints[i] < robot.limits[i].min - tol ||
                           s.joints[i] > robot.limits[i].max + tol);
  }
  json bodies = json::array();
  for (const sim::BodyPose& b : s.bodies) {
    bodies.push_back({r5(b.pos_m[0]), r5(b.pos_m[1]), r5(b.pos_m[2]), r5(b.quat_wxyz[0]),
                      r5(b.quat_wxyz[1]), r5(b.quat_wxyz[2]), r5(b.quat_wxyz[3])});
  }
  json cubes = json::array();
  for (const sim::CubeState& c : s.cubes) cubes.push_back(cube_json(c));
  json warnings = json::array();
  const std::size_t first = s.recent_warnings.size() > 8 ? s.recent_warnings.size() - 8 : 0;
  for (std::size_t i = first; i < s.recent_warnings.size(); ++i) {
    const sim::JointWarning& w = s.recent_warnings[i];
    warnings.push_back({{"t", round_to(w.time_s, 1e-3)},
                        {"joint", w.joint},
                        {"value", round_to(display_value(w.joint, w.value), 1e-3)},
                        {"min", display_value(w.joint, w.limit.min)},
                        {"max", display_value(w.joint, w.limit.max)}});
  }
  json link_json = link_figures(link);
  if (link.has_physical) {
    link_json["physical"] = display_json(link.physical);
    link_json["physical_age_s"] = round_to(link.physical_age_s, 1e-3);
  }
  json out = {{"type", "state"},
              {"t", round_to(s.time_s, 1e-4)},
              {"mode", sim::mode_name(s.mode)},
              {"twin_mode", twin_mode(s, link, extras.world_speed)},
              {"joints", joints_json(s.joints)},
              {"display", display_json(s.joints)},
              {"targets_display", display_json(s.targets)},
              {"out_of_limit", out_of_limit},
              {"tool", tool_json(s.tool)},
              {"gripper", {{"closed", s.gripper_closed}, {"held", s.held_cube}}},
              {"trajectory", s.trajectory_active},
              {"bodies", bodies},
              {"cubes", cubes},
              {"warnings", warnings},
              {"warnings_total", s.warnings_total},
              {"link", link_json},
              {"rtf", round_to(s.real_time_factor, 1e-3)},
              {"paused", s.paused},
              {"clients", extras.clients}};
  // a workcell of several robots: each one's state (robot 0's is also the fields above)
  if (s.robots.size() > 1) {
    json robots = json::array();
    for (std::size_t i = 0; i < s.robots.size(); ++i) {
      const sim::RobotSnapshot& r = s.robots[i];
      json one = {{"name", r.name},
                  {"mode", sim::mode_name(r.mode)},
                  {"display", display_json(r.joints)},
                  {"tool", tool_json(r.tool)},
                  {"gripper", {{"closed", r.gripper_closed}, {"held", r.held_cube}}},
                  {"trajectory", r.trajectory_active}};
      if (i < extras.robot_links.size()) one["link"] = link_figures(extras.robot_links[i]);
      robots.push_back(std::move(one));
    }
    out["robots"] = robots;
    out["arm_touches"] = s.arm_touches;
  }
  if (extras.with_path) {
    json path = json::array();
    for (const sim::ToolPoint& p : s.tool_path) {
      path.push_back(r5(p.pos_m[0]));
      path.push_back(r5(p.pos_m[1]));
      path.push_back(r5(p.pos_m[2]));
    }
    out["path"] = path;
  }
  return out.dump();
}

Result<Command> parse_command(std::string_view text) {
  const auto bad = [](const std::string& what) -> Error {
    return Error{static_cast<int>(WebError::kBadCommand), what};
  };
  const json j = json::parse(text, nullptr, /*allow_exceptions=*/false);
  if (j.is_discarded() || !j.is_object()) return bad("a command must be a JSON object");
  Command c;
  if (j.contains("id")) {
    if (!j["id"].is_number_integer()) return bad("\"id\" must be an integer");
    c.id = j["id"].get<std::int64_t>();
  }
  if (!j.contains("cmd") || !j["cmd"].is_string()) {
    return bad("missing \"cmd\": one of spawn, reset, shoot, ping");
  }
  const std::string cmd = j["cmd"].get<std::string>();
  if (cmd == "reset") {
    c.kind = Command::Kind::kReset;
  } else if (cmd == "shoot") {
    c.kind = Command::Kind::kShoot;
  } else if (cmd == "ping") {
    c.kind = Command::Kind::kPing;
  } else if (cmd == "spawn") {
    c.kind = Command::Kind::kSpawn;
    if (!j.contains("color") || !j["color"].is_string()) {
      return bad("spawn needs \"color\": red, green or blue");
    }
    auto color = parse_color(j["color"].get<std::string>());
    if (!color) {
      return bad(
          fmt::format("colour \"{}\": must be red, green or blue", j["color"].get<std::string>()));
    }
    c.color = *color;
    const bool has_x = j.contains("x_mm") && !j["x_mm"].is_null();
    const bool has_y = j.contains("y_mm") && !j["y_mm"].is_null();
    if (has_x != has_y) return bad("spawn needs both x_mm and y_mm, or neither");
    if (has_x) {
      if (!j["x_mm"].is_number() || !j["y_mm"].is_number()) {
        return bad("x_mm and y_mm must be numbers (millimetres in the robot base frame)");
      }
      const double x = j["x_mm"].get<double>();
      const double y = j["y_mm"].get<double>();
      if (!std::isfinite(x) || !std::isfinite(y)) return bad("x_mm and y_mm must be finite");
      c.x_m = x * 1e-3;
      c.y_m = y * 1e-3;
    }
  } else {
    return bad(fmt::format("unknown command \"{}\": one of spawn, reset, shoot, ping", cmd));
  }
  return c;
}

std::string error_reply(std::optional<std::int64_t> id, const std::string& message) {
  json out = {{"type", "reply"}, {"ok", false}, {"error", message}};
  if (id) out["id"] = *id;
  return out.dump();
}

std::string execute_command(sim::World& world, const Command& command, std::mt19937_64& rng) {
  switch (command.kind) {
    case Command::Kind::kPing:
      return reply(command, true);
    case Command::Kind::kReset:
      world.with_simulation([](sim::Simulation& s) { s.reset_scene(); });
      return reply(command, true);
    case Command::Kind::kSpawn: {
      auto cube = world.with_simulation([&](sim::Simulation& s) -> Result<sim::CubeState> {
        if (command.x_m && command.y_m)
          return s.spawn_cube(command.color, *command.x_m, *command.y_m);
        return spawn_at_random(s, command.color, rng);
      });
      if (!cube) return reply(command, false, {{"error", cube.error().message}});
      return reply(command, true, {{"cube", cube_json(*cube)}});
    }
    case Command::Kind::kShoot:
      return shoot_message(world, command);
  }
  return error_reply(command.id, "unhandled command");
}

std::string shoot_message(sim::World& world, const Command& command) {
  auto png = world.shoot_png();
  if (!png) return reply(command, false, {{"error", png.error().message}});
  const CameraModel& cam = world.robot().scene.camera;
  json out = {{"type", "image"},
              {"width", cam.width_px},
              {"height", cam.height_px},
              {"bytes", png->size()},
              {"png_base64", base64(*png)}};
  if (command.id) out["id"] = *command.id;
  return out.dump();
}

}  // namespace scaratwin::web
