// The control statements for Python, against a running simulator and robot: the hub library
// (scaratwin/hub) does the work exactly as the `scaratwin` command does (the statements are
// parsed and run by the same parse_statement()/execute(), so the errors read the same).
//
// Every blocking call runs on a worker thread with the GIL released while the calling thread
// watches for Python signals every 50 ms: Ctrl-C (KeyboardInterrupt) stops the robot through
// Hub::interrupt(), waits for the statement to end, and then raises KeyboardInterrupt. The
// session goes on afterwards (Hub::clear_interrupt()): the next home or move clears the halt.
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <fstream>
#include <mutex>
#include <optional>
#include <thread>

#include <fmt/format.h>
#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>

#include "common.hpp"
#include "scaratwin/core/units.hpp"
#include "scaratwin/hub/hub.hpp"
#include "scaratwin/hub/runner.hpp"
#include "scaratwin/hub/script.hpp"
#include "scaratwin/vision/vision.hpp"

namespace scaratwin::python {
namespace {

struct Twin {
  RobotPtr robot;
  std::unique_ptr<TwinDb> db;  // declared before the hub: destroyed after it
  std::unique_ptr<Hub> hub;

  Hub& live(const char* call) {
    if (!hub) throw py::value_error(fmt::format("{}: the twin is closed", call));
    return *hub;
  }
};
using TwinPtr = std::shared_ptr<Twin>;

// Runs `f` (which returns a Result) off the GIL; turns Ctrl-C into a stop of the robot and a
// KeyboardInterrupt, and an error into the exception of `kind`.
template <typename F>
auto blocking(Twin& twin, const char* call, ErrorKind kind, F&& f) {
  Hub& hub = twin.live(call);
  bool interrupted = false;
  // Ctrl-C stops the robot; the statement fails at once
  auto result = run_off_gil(
      std::forward<F>(f), [&hub] { hub.interrupt(); }, interrupted);
  if (interrupted) {
    hub.clear_interrupt();
    throw py::error_already_set();
  }
  if (!result) raise(kind, result.error());
  return std::move(result).value();
}

// One statement as the command line writes it ("move 0.18 0.08 -0.015"), parsed and run by
// the same code as `scaratwin move ...`; returns the line the command prints.
std::string statement(Twin& twin, const std::string& text) {
  auto st = parse_statement(text, 0);
  if (!st) raise(ErrorKind::kStatement, st.error());
  Hub& hub = twin.live(st->source.c_str());
  return blocking(twin, "statement", ErrorKind::kStatement, [&]() -> Result<std::string> {
    std::string line;
    const Status s = execute(hub, *st, [&](const Statement&, const std::string& r) { line = r; });
    if (!s) return s.error();
    return line;
  });
}

std::string num(double v) { return fmt::format("{}", v); }

void require_finite_args(const char* call, std::initializer_list<double> values) {
  for (double v : values) {
    if (!std::isfinite(v)) {
      throw py::value_error(fmt::format("{}: arguments must be finite numbers, got {}", call, v));
    }
  }
}

std::string pose_statement(const char* word, double x, double y, double z,
                           const std::optional<double>& yaw_rad) {
  require_finite_args(word, {x, y, z, yaw_rad.value_or(0.0)});
  std::string text = fmt::format("{} {} {} {}", word, num(x), num(y), num(z));
  if (yaw_rad) text += " " + num(rad_to_deg(*yaw_rad));
  return text;
}

// Runs a statement that has no text form here (its result is not a line) with the same
// event record and error prefix as execute().
template <typename F>
auto direct(Twin& twin, const std::string& source, F&& f) {
  Hub& hub = twin.live(source.c_str());
  hub.record_event("statement", source);
  return blocking(twin, "statement", ErrorKind::kStatement, [&]() {
    auto r = f(hub);
    if (!r) {
      hub.record_event("error", r.error().message);
      return decltype(r)(Error{r.error().code, fmt::format("{}: {}", source, r.error().message)});
    }
    return r;
  });
}

py::dict physical_dict(const PhysicalState& ps) {
  py::dict d;
  py::array_t<double> q(4);
  for (int j = 0; j < 4; ++j) q.mutable_at(j) = ps.q[j];
  py::array_t<std::int32_t> steps(3);
  for (int j = 0; j < 3; ++j) steps.mutable_at(j) = ps.raw.steps[j];
  d["q"] = q;
  d["steps"] = steps;
  d["grip_deg"] = ps.grip_deg;
  d["seq"] = ps.raw.seq;
  d["device_t_us"] = ps.raw.t_us;
  d["flags"] = ps.raw.flags;
  d["queue_free"] = ps.raw.queue_free;
  d["rx_steady_us"] = ps.rx_steady_us;
  return d;
}

py::array image_array(const RgbImage& img) {
  py::array_t<std::uint8_t> a({img.height, img.width, 3});
  std::memcpy(a.mutable_data(), img.rgb.data(), img.rgb.size());
  return a;
}

TwinPtr connect(const py::object& serial, const std::string& sim, const py::object& db_path,
                const py::object& robot, bool mirror, const std::string& label) {
  auto twin = std::make_shared<Twin>();
  twin->robot = robot_or_default(robot);
  HubOptions o;
  if (!serial.is_none()) o.serial_device = serial.cast<std::string>();
  if (o.serial_device.empty()) {
    if (const char* env = std::getenv("SCARATWIN_SERIAL")) o.serial_device = env;
  }
  if (o.serial_device.empty()) {
    throw py::value_error(
        "connect: no robot: pass serial=DEVICE or set SCARATWIN_SERIAL (start one with "
        "`scaratwin robot`)");
  }
  const size_t colon = sim.rfind(':');
  int port = 0;
  try {
    port = colon == std::string::npos ? 0 : std::stoi(sim.substr(colon + 1));
  } catch (...) {
  }
  if (colon == std::string::npos || port <= 0 || port > 65535) {
    throw py::value_error(fmt::format("connect: sim '{}': expected HOST:PORT", sim));
  }
  o.sim_host = sim.substr(0, colon);
  o.sim_port = static_cast<std::uint16_t>(port);
  // a simulator listening beyond this machine asks for its token (docs/security.md)
  if (const char* env = std::getenv("SCARATWIN_TOKEN")) o.sim_token = env;
  if (!db_path.is_none()) {
    auto d = TwinDb::open(db_path.cast<std::filesystem::path>());
    if (!d) raise(ErrorKind::kDatabase, d.error());
    twin->db = std::move(*d);
  }
  Result<std::unique_ptr<Hub>> hub = Error{};
  {
    py::gil_scoped_release nogil;
    hub = Hub::connect(twin->robot->model, o, twin->db.get());
  }
  if (!hub) raise(ErrorKind::kLink, hub.error());
  twin->hub = std::move(*hub);
  (void)twin->hub->begin_run("python", label);
  twin->hub->set_mirror(mirror);
  return twin;
}

void close(Twin& twin, bool ok) {
  if (!twin.hub) return;
  py::gil_scoped_release nogil;
  (void)twin.hub->end_run(ok);
  twin.hub.reset();
  twin.db.reset();
}

}  // namespace

void bind_twin(py::module_& m) {
  py::class_<Twin, TwinPtr>(
      m, "Twin",
      "A connected twin (scaratwin.connect()): the physical robot on its serial port and the "
      "virtual robot in the simulator, with the hub between them recording into the twin "
      "database. Blocking calls release the GIL; Ctrl-C during one stops the robot and raises "
      "KeyboardInterrupt. A statement that fails raises StatementError with the message the "
      "scaratwin command prints (after its 'scaratwin NAME: ' prefix).")
      .def_property_readonly(
          "robot", [](const Twin& t) { return t.robot; }, "The robot description in use.")
      .def_property_readonly(
          "run_id", [](Twin& t) { return t.live("run_id").current_run(); },
          "The twin database's run this session records into.")
      .def_property_readonly(
          "closed", [](const Twin& t) { return !t.hub; }, "True after close().")
      .def(
          "home", [](Twin& t) { return statement(t, "home"); },
          "Homes the physical robot against its endstops. Returns the command's line.")
      .def(
          "stop", [](Twin& t) { return statement(t, "stop"); },
          "Stops the physical robot at once; halted until the next home or motion.")
      .def(
          "move",
          [](Twin& t, double x, double y, double z, std::optional<double> yaw) {
            return statement(t, pose_statement("move", x, y, z, yaw));
          },
          py::arg("x_m"), py::arg("y_m"), py::arg("z_m"), py::arg("yaw_rad") = py::none(),
          "Moves the tool to (x_m, y_m, z_m[, yaw_rad]): IK nearest the current joints, a "
          "60-sample quintic; the virtual robot follows. Nothing moves when it is unreachable.")
      .def(
          "line",
          [](Twin& t, double x, double y, double z, std::optional<double> yaw) {
            return statement(t, pose_statement("line", x, y, z, yaw));
          },
          py::arg("x_m"), py::arg("y_m"), py::arg("z_m"), py::arg("yaw_rad") = py::none(),
          "Moves the tool in a straight line (yaw kept when None).")
      .def(
          "movej",
          [](Twin& t, const py::object& joints) {
            const Rows r = rows_of(joints, "movej", "joints");
            if (!r.single) throw py::value_error("movej: joints must have shape (4,)");
            require_finite(r, "movej", "joints");
            return statement(
                t, fmt::format("movej {} {} {} {}", num(r.ptr()[0]), num(rad_to_deg(r.ptr()[1])),
                               num(rad_to_deg(r.ptr()[2])), num(rad_to_deg(r.ptr()[3]))));
          },
          py::arg("joints"), "Moves the joints to (d1_m, q2_rad, q3_rad, q4_rad).")
      .def(
          "grip", [](Twin& t) { return statement(t, "grip"); }, "Closes the gripper.")
      .def(
          "release", [](Twin& t) { return statement(t, "release"); }, "Opens the gripper.")
      .def(
          "reset", [](Twin& t) { return statement(t, "reset"); },
          "Removes every cube from the virtual scene.")
      .def(
          "sort", [](Twin& t) { return statement(t, "sort"); },
          "Camera shot, colour recognition, every cube picked and placed in its tray.")
      .def(
          "pick", [](Twin& t, int id) { return statement(t, fmt::format("pick {}", id)); },
          py::arg("cube_id"), "Picks cube `cube_id` and places it in the tray of its colour.")
      .def(
          "wait",
          [](Twin& t, double s) {
            require_finite_args("wait", {s});
            return statement(t, fmt::format("wait {}", num(s)));
          },
          py::arg("seconds"), "Waits (Ctrl-C ends it).")
      .def(
          "run_script",
          [](Twin& t, const std::string& text, const std::string& name) {
            auto script = parse_script(text, name);
            if (!script) raise(ErrorKind::kStatement, script.error());
            Hub& hub = t.live("run_script");
            return blocking(t, "run_script", ErrorKind::kStatement, [&]() -> Result<py::ssize_t> {
              const Status s = run_script(hub, *script, name);
              if (!s) return s.error();
              return static_cast<py::ssize_t>(script->size());
            });
          },
          py::arg("text"), py::arg("name") = "<script>",
          "Runs a script (one statement per line, as `scaratwin run`): parsed completely before "
          "anything moves; the first failing statement stops it. Returns the statement count.")
      .def(
          "spawn",
          [](Twin& t, const std::string& color, double x, double y) {
            require_finite_args("spawn", {x, y});
            auto c = parse_color(color);
            if (!c) throw py::value_error(fmt::format("spawn: {}", c.error().message));
            const std::string source = fmt::format("spawn {} {} {}", color, num(x), num(y));
            return direct(t, source, [&](Hub& h) { return h.spawn_cube(*c, x, y); });
          },
          py::arg("color"), py::arg("x_m"), py::arg("y_m"),
          "Spawns a cube ('red', 'green', 'blue') on the virtual table; returns its id.")
      .def(
          "shoot",
          [](Twin& t, const py::object& path) {
            std::string png = direct(t, "shoot", [&](Hub& h) { return h.shoot(); });
            if (!path.is_none()) {
              const auto p = path.cast<std::filesystem::path>();
              std::ofstream out(p, std::ios::binary);
              out.write(png.data(), static_cast<std::streamsize>(png.size()));
              if (!out) {
                raise(ErrorKind::kStatement,
                      Error{ScriptError::kWriteFailed,
                            fmt::format("shoot: cannot write '{}'", p.string())});
              }
            }
            auto img = decode_png(png);
            if (!img) raise(ErrorKind::kStatement, img.error());
            return image_array(*img);
          },
          py::arg("path") = py::none(),
          "Takes a picture with the virtual camera: an (H, W, 3) uint8 RGB array, row 0 at the "
          "top; with path also saves the PNG.")
      .def(
          "objects",
          [](Twin& t) {
            auto objs = direct(t, "objects", [&](Hub& h) { return h.objects(); });
            py::list rows;
            for (const protocol::ObjectPose& o : objs) {
              rows.append(
                  py::make_tuple(o.id, color_name(o.color), o.x_m, o.y_m, o.z_m, o.yaw_rad));
            }
            py::list dtype;
            dtype.append(py::make_tuple("id", "i4"));
            dtype.append(py::make_tuple("color", "U5"));
            for (const char* f : {"x_m", "y_m", "z_m", "yaw_rad"}) {
              dtype.append(py::make_tuple(f, "f8"));
            }
            return py::module_::import("numpy").attr("array")(rows, py::arg("dtype") = dtype);
          },
          "The cubes of the virtual scene: a structured array (id, color, x_m, y_m, z_m, "
          "yaw_rad).")
      .def(
          "mirror",
          [](Twin& t, double seconds) {
            require_finite_args("mirror", {seconds});
            Hub& hub = t.live("mirror");
            hub.set_mirror(true);
            const MirrorCounters before = hub.mirror_counters();
            const std::string source = fmt::format("mirror {}", num(seconds));
            direct(t, source, [&](Hub& h) -> Result<int> {
              if (Status s = h.sleep(seconds); !s) return s.error();
              return 0;
            });
            const MirrorCounters after = hub.mirror_counters();
            py::dict d;
            d["frames"] = after.applied - before.applied;
            d["lost"] = after.lost - before.lost;
            d["mean_latency_ms"] = after.mean_latency_ms;
            d["last_latency_ms"] = after.last_latency_ms;
            return d;
          },
          py::arg("seconds"),
          "Mirrors the physical robot in the virtual one for `seconds`: frames, lost frames and "
          "latency.")
      .def(
          "run_trajectory",
          [](Twin& t, const py::object& traj) {
            const JointTrajectory& jt = trajectory_of(traj);
            const std::string source = fmt::format("trajectory of {} samples", jt.samples.size());
            return direct(t, source, [&](Hub& h) { return h.run_trajectory(jt); });
          },
          py::arg("trajectory"),
          "Runs a Trajectory on the physical robot (its first sample must be the current "
          "joints); the virtual robot mirrors it. Returns the number of points run.")
      .def(
          "state",
          [](Twin& t, double timeout_s) {
            Hub& hub = t.live("state");
            auto ps = blocking(t, "state", ErrorKind::kLink,
                               [&] { return hub.fresh_physical(timeout_s); });
            return physical_dict(ps);
          },
          py::arg("timeout_s") = 2.0,
          "The next state report of the physical robot: q (4,) from the step counts, steps "
          "(3,), grip_deg, seq, device_t_us, flags, queue_free, rx_steady_us.")
      .def(
          "virtual_state",
          [](Twin& t) {
            auto s = direct(t, "virtual_state", [&](Hub& h) { return h.sim_state(); });
            py::dict d;
            py::array_t<double> q(4);
            for (int j = 0; j < 4; ++j) q.mutable_at(j) = s.q[j];
            d["q"] = q;
            d["grip_closed"] = s.grip_closed;
            d["held_id"] = s.held_id;
            d["seq"] = s.seq;
            d["t_us"] = s.t_us;
            return d;
          },
          "The virtual robot's joints (4,), gripper and held cube.")
      .def(
          "mirror_counters",
          [](Twin& t) {
            const MirrorCounters c = t.live("mirror_counters").mirror_counters();
            py::dict d;
            d["frames"] = c.frames;
            d["applied"] = c.applied;
            d["lost"] = c.lost;
            d["last_latency_ms"] = c.last_latency_ms;
            d["mean_latency_ms"] = c.mean_latency_ms;
            return d;
          },
          "The mirror's counters since connect().")
      .def(
          "set_mirror", [](Twin& t, bool on) { t.live("set_mirror").set_mirror(on); },
          py::arg("on"), "Forwards every state report to the simulator while on.")
      .def(
          "close", [](Twin& t) { close(t, true); },
          "Ends the run in the twin database and closes both links (also on `with` exit).")
      .def("__enter__", [](const TwinPtr& t) { return t; })
      .def("__exit__", [](Twin& t, const py::object& type, const py::object&, const py::object&) {
        close(t, type.is_none());
      });

  m.def(
      "detect_cubes",
      [](const py::object& image, const py::object& robot) {
        const RobotPtr r = robot_or_default(robot);
        auto a = py::array_t<std::uint8_t, py::array::c_style>::ensure(image);
        if (!a || a.ndim() != 3 || a.shape(2) != 3 || a.dtype().kind() != 'u') {
          throw py::value_error("detect_cubes: image must be an (H, W, 3) uint8 RGB array");
        }
        RgbImage img;
        img.height = static_cast<int>(a.shape(0));
        img.width = static_cast<int>(a.shape(1));
        img.rgb.assign(a.data(), a.data() + a.size());
        std::vector<CubeDetection> found;
        {
          py::gil_scoped_release nogil;
          found = detect_cubes(img, r->model);
        }
        py::list rows;
        for (const CubeDetection& d : found) {
          rows.append(py::make_tuple(color_name(d.color), d.col, d.row, d.area_px, d.x_m, d.y_m));
        }
        py::list dtype;
        dtype.append(py::make_tuple("color", "U5"));
        dtype.append(py::make_tuple("col", "f8"));
        dtype.append(py::make_tuple("row", "f8"));
        dtype.append(py::make_tuple("area_px", "i4"));
        dtype.append(py::make_tuple("x_m", "f8"));
        dtype.append(py::make_tuple("y_m", "f8"));
        return py::module_::import("numpy").attr("array")(rows, py::arg("dtype") = dtype);
      },
      py::arg("image"), py::arg("robot") = py::none(),
      "The paper's colour recognition on a picture of the overhead camera (shoot()): the red, "
      "green and blue cubes as a structured array (color, col, row, area_px, x_m, y_m), their "
      "centres on the table in the base frame through the description's camera model.");

  m.def("connect", &connect, py::arg("serial") = py::none(), py::arg("sim") = "127.0.0.1:55016",
        py::arg("db") = "scaratwin-out/twin.db", py::arg("robot") = py::none(),
        py::arg("mirror") = true, py::arg("label") = "python",
        "Connects to the robot (serial: its port, default $SCARATWIN_SERIAL) and the simulator "
        "(sim: HOST:PORT), records into the twin database `db` (None: nothing recorded) as one "
        "run, and starts the digital mirror. Raises LinkError when either is not running.");
}

}  // namespace scaratwin::python
