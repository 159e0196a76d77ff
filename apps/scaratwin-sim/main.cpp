// scaratwin-sim: the virtual robot as a server process (`scaratwin sim` runs it). MuJoCo
// physics of the SCARA and its sorting scene, the overhead camera rendered offscreen, and the
// protocol's virtual link on TCP (default 127.0.0.1:55016).
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <deque>
#include <random>
#include <thread>

#include <fmt/format.h>
#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "scaratwin/config/robot_config.hpp"
#include "scaratwin/config/workcell_config.hpp"
#include "scaratwin/core/units.hpp"
#include "scaratwin/fleet/fleet_watch.hpp"
#include "scaratwin/hub/process.hpp"
#include "scaratwin/sim/companion.hpp"
#include "scaratwin/sim/server.hpp"
#include "scaratwin/sim/world.hpp"
#include "scaratwin/web/link_monitor.hpp"
#include "scaratwin/web/web_server.hpp"

namespace {

volatile std::sig_atomic_t g_stop = 0;
extern "C" void on_signal(int) { g_stop = 1; }

struct Args {
  std::string config_path;
  std::string workcell_path;
  std::string bind = "127.0.0.1";
  int port = 55016;
  std::string speed = "real";
  int cubes_per_color = 4;
  std::string max_image = "1280x960";
  bool shadows = false;
  bool no_camera = false;
  int png_level = 1;
  std::string save_images;
  std::string mode = "mirror";
  std::vector<std::string> spawn;
  double timestep_s = 0.004;
  double duration_s = 0.0;
  double status_s = 0.0;
  std::string http_bind = "127.0.0.1";
  int http_port = 8080;
  int ready_fd = -1;   // --ready-fd: the ready line goes there
  int parent_fd = -1;  // --parent-fd: the lifeline from the program that started it
  std::string web_root;
  std::string token;
  int companion_port = -1;  // -1: off
  std::string mqtt;         // the fleet page's broker; empty: no fleet page data
};

// 127.0.0.0/8 and ::1: only this machine can connect.
bool is_loopback(const std::string& address) {
  return address.rfind("127.", 0) == 0 || address == "::1" || address == "localhost";
}

// 32 hexadecimal digits (128 bits) from the system's random source.
std::string generate_token() {
  std::random_device rd;
  std::string t;
  for (int i = 0; i < 4; ++i) t += fmt::format("{:08x}", rd());
  return t;
}

bool valid_token(const std::string& t) {
  if (t.empty() || t.size() > 32) return false;
  for (char c : t) {
    const bool ok = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') ||
                    c == '_' || c == '.' || c == '-';
    if (!ok) return false;
  }
  return true;
}

int fail(const std::string& message, int code = 2) {
  std::fprintf(stderr, "scaratwin-sim: %s\n", message.c_str());
  return code;
}

}  // namespace

int main(int argc, char** argv) {
  using namespace scaratwin;
  Args a;
  CLI::App app{
      "scaratwin-sim: the virtual SCARA (MuJoCo physics, gripper, overhead camera) "
      "serving the protocol's virtual link",
      "scaratwin-sim"};
  app.add_option("--config", a.config_path,
                 "robot description (TOML); default: "
                 "$SCARATWIN_CONFIG or config/scara.toml");
  app.add_option("--workcell", a.workcell_path,
                 "a workcell of several robots on one table (TOML, e.g. config/two_arms.toml; "
                 "docs/workcell.md) instead of --config: robot-addressed packets carry the "
                 "robot's index (docs/protocol.md section 11.3)");
  app.add_option("--bind", a.bind, "address to listen on")->capture_default_str();
  app.add_option("--port", a.port, "TCP port (0: any free port, printed)")->capture_default_str();
  app.add_option("--speed", a.speed,
                 "pace: 'real' (1x), a factor such as 2 or 0.5, or 'max' (trajectories as fast "
                 "as possible, for prediction)")
      ->capture_default_str();
  app.add_option("--mode", a.mode, "initial mode: mirror or simulate")->capture_default_str();
  app.add_option("--cubes-per-color", a.cubes_per_color, "cube pool per colour")
      ->capture_default_str();
  app.add_option("--spawn", a.spawn, "spawn a cube at start: COLOR,X_MM,Y_MM (repeat)");
  app.add_option("--max-image", a.max_image, "largest camera image WxH (offscreen buffer)")
      ->capture_default_str();
  app.add_flag("--shadows", a.shadows, "render shadows (slower)");
  app.add_flag("--no-camera", a.no_camera, "physics only, no EGL context");
  app.add_option("--png-level", a.png_level, "zlib level of the PNGs, 0..9")->capture_default_str();
  app.add_option("--save-images", a.save_images, "also save every shot to DIR/shot_N.png");
  app.add_option("--timestep", a.timestep_s, "physics step, s")->capture_default_str();
  app.add_option("--duration", a.duration_s,
                 "exit after this many wall seconds (0: run until "
                 "SIGINT/SIGTERM)")
      ->capture_default_str();
  app.add_option("--status", a.status_s, "print a status line every N seconds (0: never)")
      ->capture_default_str();
  app.add_option("--http-port", a.http_port, "browser UI port (0: no UI)")->capture_default_str();
  app.add_option("--ready-fd", a.ready_fd,
                 "once it serves, write one JSON line on this open descriptor (port, ui_url, "
                 "fleet_url, companion_port) and close it: for the programs that start the "
                 "simulator")
      ->check(CLI::Range(3, 1023));
  app.add_option("--parent-fd", a.parent_fd,
                 "end (as on SIGTERM) once this descriptor, a pipe from the program that started "
                 "the simulator, reads its end: that program is gone, however it died")
      ->check(CLI::Range(3, 1023));
  app.add_option("--http-bind", a.http_bind, "address the browser UI listens on")
      ->capture_default_str();
  app.add_option("--token", a.token,
                 "access token every connection must present (TCP hello, browser ?token=); "
                 "default: $SCARATWIN_TOKEN, or one generated and printed when --bind or "
                 "--http-bind is not a loopback address (docs/security.md)");
  app.add_option(
      "--web-root", a.web_root,
      "folder of the built page (default: the build tree's, or <prefix>/share/scaratwin/web)");
  app.add_option("--companion-port", a.companion_port,
                 "also serve the paper's companion TCP dialect (its MATLAB/Octave scripts use "
                 "55012) on this port, 0 for any free port (default: off; docs/protocol.md "
                 "section 13)");
  app.add_option("--mqtt", a.mqtt,
                 "MQTT broker whose fleet the browser UI's fleet page shows (/fleet.html), "
                 "mqtt://[USER@]HOST[:PORT] or mqtts://[USER@]HOST[:PORT][?ca=FILE&...] (the "
                 "password from ?password-file=FILE or $SCARATWIN_MQTT_PASSWORD; docs/fleet.md)");
  CLI11_PARSE(app, argc, argv);

  if (!a.config_path.empty() && !a.workcell_path.empty()) {
    return fail(
        "--config and --workcell: give one (the workcell file names each robot's "
        "description)");
  }
  Workcell workcell;
  if (!a.workcell_path.empty()) {
    auto cell = load_workcell_config(a.workcell_path);
    if (!cell) return fail(cell.error().message);
    workcell = std::move(*cell);
  } else {
    auto one = load_robot_config_or_default(a.config_path);
    if (!one) return fail(one.error().message);
    workcell = single_robot_workcell(*one);
  }
  sim::WorldOptions wo;
  if (a.speed == "real") {
    wo.speed = 1.0;
  } else if (a.speed == "max") {
    wo.speed = 0.0;
  } else {
    try {
      wo.speed = std::stod(a.speed);
    } catch (...) {
      wo.speed = -1.0;
    }
    if (!(wo.speed > 0.0)) {
      return fail(fmt::format("--speed '{}': expected real, max or a factor > 0", a.speed));
    }
  }
  sim::SimOptions so;
  so.mjcf.cubes_per_color = a.cubes_per_color;
  so.mjcf.timestep_s = a.timestep_s;
  if (std::sscanf(a.max_image.c_str(), "%dx%d", &so.mjcf.offscreen_width_px,
                  &so.mjcf.offscreen_height_px) != 2) {
    return fail(fmt::format("--max-image '{}': expected WxH, e.g. 1280x960", a.max_image));
  }
  so.mjcf.offscreen_width_px = std::max(so.mjcf.offscreen_width_px, workcell.scene.camera.width_px);
  so.mjcf.offscreen_height_px =
      std::max(so.mjcf.offscreen_height_px, workcell.scene.camera.height_px);
  wo.camera = !a.no_camera;
  wo.render.shadows = a.shadows;
  wo.png_level = a.png_level;
  if (a.png_level < 0 || a.png_level > 9) return fail("--png-level: expected 0..9");
  if (a.port < 0 || a.port > 65535)
    return fail(fmt::format("--port {}: expected 0..65535", a.port));
  if (a.mode != "mirror" && a.mode != "simulate") {
    return fail(fmt::format("--mode '{}': expected mirror or simulate", a.mode));
  }

  auto world = sim::World::create(workcell, so, wo);
  if (!world) return fail(world.error().message, 1);
  if (a.mode == "simulate") {
    (*world)->with_simulation([](sim::Simulation& s) {
      for (int r = 0; r < s.robot_count(); ++r) s.set_mode(sim::Mode::kSimulate, r);
    });
  }
  for (const std::string& spec : a.spawn) {
    char color[16] = {0};
    double x_mm = 0, y_mm = 0;
    if (std::sscanf(spec.c_str(), "%15[a-z],%lf,%lf", color, &x_mm, &y_mm) != 3) {
      return fail(fmt::format("--spawn '{}': expected COLOR,X_MM,Y_MM", spec));
    }
    auto c = parse_color(color);
    if (!c) return fail(fmt::format("--spawn '{}': {}", spec, c.error().message));
    auto r = (*world)->with_simulation(
        [&](sim::Simulation& s) { return s.spawn_cube(*c, mm_to_m(x_mm), mm_to_m(y_mm)); });
    if (!r) return fail(fmt::format("--spawn '{}': {}", spec, r.error().message));
  }

  // access: loopback needs no token; any other address does (given, or generated here)
  if (a.token.empty()) {
    if (const char* env = std::getenv("SCARATWIN_TOKEN"); env != nullptr) a.token = env;
  }
  if (!a.token.empty() && !valid_token(a.token)) {
    return fail("--token / SCARATWIN_TOKEN: expected 1..32 characters of A-Z a-z 0-9 _ . -");
  }
  const bool exposed = !is_loopback(a.bind) || (a.http_port != 0 && !is_loopback(a.http_bind));
  if (exposed && a.token.empty()) {
    a.token = generate_token();
    std::printf(
        "scaratwin-sim: listening beyond this machine: access token %s (give it to the "
        "hub with --sim-token or SCARATWIN_TOKEN, to the browser as ?token=)\n",
        a.token.c_str());
  }

  sim::ServerOptions serve;
  serve.token = a.token;
  serve.bind_address = a.bind;
  serve.port = static_cast<std::uint16_t>(a.port);
  serve.save_images_dir = a.save_images;
  // one link monitor per robot: the page's link panel is robot 0's, the Robots table shows
  // each robot's (a workcell's hubs each drive one robot)
  std::deque<web::LinkMonitor> monitors((*world)->robot_count());
  web::LinkMonitor& link_monitor = monitors.front();
  serve.on_joint_frame = [&monitors](const sim::JointFrame& f) {
    if (f.robot >= 0 && f.robot < static_cast<int>(monitors.size())) {
      monitors[static_cast<std::size_t>(f.robot)].on_joint_frame(f.seq, f.t_us, f.q, f.applied_us);
    }
  };
  // a new hub (its hello) or a mode switch starts a new stream of frames, decided on the
  // server's thread in order with the frames (the feed's polling of the connection state can
  // miss a hub that left and another that came between two polls)
  serve.on_new_stream = [&monitors](int robot) {
    if (robot >= 0 && robot < static_cast<int>(monitors.size())) {
      monitors[static_cast<std::size_t>(robot)].restart_sequence();
    }
  };
  serve.on_twin_phase = [&link_monitor](const std::string& phase) {
    link_monitor.set_twin_mode(phase);
  };
  auto server = sim::SimServer::create(**world, serve);
  if (!server) return fail(server.error().message, 1);
  // the browser UI: a busy port or a missing page is reported, the simulator runs on
  std::unique_ptr<web::WebServer> web_ui;
  if (a.http_port < 0 || a.http_port > 65535) {
    return fail(fmt::format("--http-port {}: expected 0..65535 (0: no UI)", a.http_port));
  }
  std::unique_ptr<fleet::FleetWatcher> fleet_watch;
  std::string fleet_broker;  // scheme, user, host and port, never the password
  if (!a.mqtt.empty()) {
    auto broker = fleet::parse_broker_url(a.mqtt);
    if (!broker) return fail(fmt::format("--mqtt: {}", broker.error().message));
    if (a.http_port == 0) return fail("--mqtt: the fleet page needs the browser UI (--http-port)");
    auto w = fleet::FleetWatcher::start(*broker, [](const std::string& line) {
      std::fprintf(stderr, "scaratwin-sim: %s\n", line.c_str());
    });
    if (!w) return fail(fmt::format("--mqtt: {}", w.error().message), 1);
    fleet_watch = std::move(*w);
    fleet_broker = fleet::broker_label(*broker);
  }
  if (a.http_port != 0) {
    web::WebOptions wo_web;
    if (fleet_watch) {
      wo_web.fleet = [w = fleet_watch.get()] { return w->snapshot_json(); };
    }
    wo_web.bind_address = a.http_bind;
    wo_web.token = a.token;
    wo_web.port = static_cast<std::uint16_t>(a.http_port);
    if (!a.web_root.empty()) wo_web.root_dir = a.web_root;
    sim::SimServer* srv = server->get();
    if (monitors.size() > 1) {
      wo_web.robot_links = [&monitors, srv, was = std::vector<char>(monitors.size(), 0)]() mutable {
        std::vector<web::LinkStatus> out;
        for (std::size_t r = 0; r < monitors.size(); ++r) {
          const bool now = srv->robot_controlled(static_cast<int>(r));
          if (r > 0 && now != static_cast<bool>(was[r])) {
            monitors[r].set_connected(now);  // robot 0's follows the link panel's below
            was[r] = now;
          }
          out.push_back(monitors[r].status());
        }
        return out;
      };
    }
    auto ui = web::WebServer::create(**world, wo_web, [&link_monitor, srv, was = false]() mutable {
      if (const bool now = srv->peer_connected(); now != was) {
        link_monitor.set_connected(now);  // a new hub starts a new sequence
        was = now;
      }
      return link_monitor.status();
    });
    if (ui) {
      web_ui = std::move(*ui);
    } else {
      std::fprintf(stderr, "scaratwin-sim: no browser UI: %s\n", ui.error().message.c_str());
    }
  }
  std::unique_ptr<sim::CompanionServer> companion;
  if (a.companion_port < -1 || a.companion_port > 65535) {
    return fail(
        fmt::format("--companion-port {}: expected 0..65535 (0: any free port)", a.companion_port));
  }
  if (a.companion_port >= 0) {
    sim::CompanionOptions co;
    // the paper's scripts send no token: the companion dialect stays on this machine
    co.bind_address = "127.0.0.1";
    co.port = static_cast<std::uint16_t>(a.companion_port);
    auto c = sim::CompanionServer::create(**world, co);
    if (!c) return fail(c.error().message, 1);
    companion = std::move(*c);
  }
  std::signal(SIGINT, on_signal);
  std::signal(SIGTERM, on_signal);
  if (a.parent_fd >= 0) exit_with_parent_fd(a.parent_fd);
  (*world)->start();
  std::printf("scaratwin-sim: listening on %s:%u (speed %s, mode %s, camera %s)\n", a.bind.c_str(),
              (*server)->port(), a.speed.c_str(), a.mode.c_str(), wo.camera ? "on" : "off");
  if (companion) {
    std::printf("scaratwin-sim: companion dialect on 127.0.0.1:%u\n", companion->port());
  }
  if (web_ui) {
    std::printf("scaratwin-sim: browser UI on http://%s:%u/\n", a.http_bind.c_str(),
                web_ui->port());
    if (fleet_watch) {
      std::printf("scaratwin-sim: fleet page on http://%s:%u/fleet.html (broker %s)\n",
                  a.http_bind.c_str(), web_ui->port(), fleet_broker.c_str());
    }
  }
  std::fflush(stdout);
  if (a.ready_fd >= 0) {
    nlohmann::json ready = {{"program", "scaratwin-sim"}, {"port", (*server)->port()}};
    if (companion) ready["companion_port"] = companion->port();
    if (web_ui) {
      ready["ui_url"] = fmt::format("http://{}:{}/", a.http_bind, web_ui->port());
      if (fleet_watch) {
        ready["fleet_url"] = fmt::format("http://{}:{}/fleet.html", a.http_bind, web_ui->port());
      }
    }
    if (Status st = announce_ready(a.ready_fd, ready.dump()); !st)
      return fail(st.error().message, 1);
  }

  const auto start = std::chrono::steady_clock::now();
  auto next_status = start;
  while (!g_stop) {
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
    const auto now = std::chrono::steady_clock::now();
    if (a.duration_s > 0 && now - start >= std::chrono::duration<double>(a.duration_s)) break;
    if (a.status_s > 0 && now >= next_status) {
      next_status = now + std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                              std::chrono::duration<double>(a.status_s));
      const sim::Snapshot s = (*world)->snapshot();
      const auto c = (*server)->counters();
      const std::string phase = link_monitor.status().twin_mode;
      std::printf(
          "t %.2f s  rtf %.2f  %s  d1 %.1f mm q2 %.1f q3 %.1f q4 %.1f deg  cubes %zu  "
          "packets %llu errors %llu images %llu  limit warnings %llu  phase %s\n",
          s.time_s, s.real_time_factor, sim::mode_name(s.mode), m_to_mm(s.joints[0]),
          rad_to_deg(s.joints[1]), rad_to_deg(s.joints[2]), rad_to_deg(s.joints[3]), s.cubes.size(),
          static_cast<unsigned long long>(c.packets),
          static_cast<unsigned long long>(c.errors_sent),
          static_cast<unsigned long long>(c.images_sent),
          static_cast<unsigned long long>(s.warnings_total), phase.empty() ? "-" : phase.c_str());
      std::fflush(stdout);
    }
  }
  web_ui.reset();
  fleet_watch.reset();
  companion.reset();
  (*server).reset();
  (*world)->stop();
  return 0;
}
