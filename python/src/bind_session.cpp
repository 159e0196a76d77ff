// The paper's procedures for Python through the session library (scaratwin/session), exactly as
// `scaratwin demo` and `scaratwin calibrate` run them: scaratwin.demo() and
// scaratwin.calibrate() start the simulator and the emulated robot, run the procedure and
// return its figures. Each line the procedure says goes to `on_line` (default: printed).
//
// The procedure runs on a worker thread with the GIL released; `on_line` is called with it held.
// Ctrl-C (or an exception raised by `on_line`) stops the robot at once through the session's
// stop; the procedure ends at its next step, its report written, and then the KeyboardInterrupt
// (or that exception) is raised.
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <filesystem>
#include <mutex>
#include <optional>
#include <string>
#include <thread>

#include <fmt/format.h>
#include <pybind11/functional.h>
#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>

#include "common.hpp"
#include "scaratwin/session/calibration.hpp"
#include "scaratwin/session/demo.hpp"

namespace scaratwin::python {
namespace {

namespace fs = std::filesystem;

// The lines of a procedure, to a Python callable (or print). The first exception the callable
// raises stops the procedure (`stop`) and is raised when it has ended; later lines are dropped.
class Lines {
 public:
  Lines(py::object on_line, std::atomic<bool>& stop) : on_line_(std::move(on_line)), stop_(stop) {}
  session::Say say() {
    return [this](const std::string& line) {
      py::gil_scoped_acquire gil;
      if (failed_) return;
      try {
        if (on_line_.is_none()) {
          py::print(line, py::arg("flush") = true);
        } else {
          on_line_(line);
        }
      } catch (py::error_already_set& e) {
        failed_.emplace(std::move(e));
        stop_ = true;
      }
    };
  }
  // Raises what the callable raised, if it did.
  void rethrow() {
    if (failed_) {
      py::error_already_set e = std::move(*failed_);
      failed_.reset();
      throw e;
    }
  }

 private:
  py::object on_line_;
  std::atomic<bool>& stop_;
  std::optional<py::error_already_set> failed_;
};

fs::path out_folder(const fs::path& out, const char* call) {
  std::error_code ec;
  fs::create_directories(out, ec);
  if (ec) {
    throw py::value_error(
        fmt::format("{}: cannot create out folder '{}': {}", call, out.string(), ec.message()));
  }
  return fs::absolute(out);
}

py::object bin_dir() { return py::module_::import("scaratwin").attr("bin_dir")(); }

struct PyDemoResult {
  session::DemoResult r;
};

struct PyCalibrationResult {
  session::CalibrateResult r;
};

}  // namespace

void bind_session(py::module_& m) {
  py::class_<PyDemoResult>(m, "DemoResult",
                           "What scaratwin.demo() measured (results.json has every figure).")
      .def_property_readonly(
          "ok", [](const PyDemoResult& d) { return d.r.ok; },
          "every cube in its tray, no frame lost")
      .def_property_readonly("plant", [](const PyDemoResult& d) { return d.r.plant; })
      .def_property_readonly(
          "run", [](const PyDemoResult& d) { return d.r.demo_run; },
          "the session's run in the database")
      .def_property_readonly("duration_s", [](const PyDemoResult& d) { return d.r.duration_s; })
      .def_property_readonly("cubes_in_trays",
                             [](const PyDemoResult& d) { return d.r.cubes_in_trays; })
      .def_property_readonly("database", [](const PyDemoResult& d) { return d.r.database; })
      .def_property_readonly(
          "results",
          [](const PyDemoResult& d) -> py::object {
            return d.r.results.empty() ? py::none() : py::cast(d.r.results);
          },
          "results.json (None when it could not be written)")
      .def_property_readonly("report",
                             [](const PyDemoResult& d) -> py::object {
                               return d.r.report.empty() ? py::none() : py::cast(d.r.report);
                             })
      .def_property_readonly("csv_dir", [](const PyDemoResult& d) { return d.r.csv_dir; })
      .def_property_readonly(
          "failure",
          [](const PyDemoResult& d) -> py::object {
            return d.r.failure ? py::cast(d.r.failure->message) : py::none();
          },
          "why a phase failed (None when every phase ran)")
      .def_property_readonly("failure_code",
                             [](const PyDemoResult& d) -> py::object {
                               return d.r.failure ? py::cast(d.r.failure->code) : py::none();
                             })
      .def_property_readonly("lost_frames",
                             [](const PyDemoResult& d) -> py::object {
                               return d.r.outcome ? py::cast(d.r.outcome->lost_frames) : py::none();
                             })
      .def_property_readonly(
          "latency_mean_ms",
          [](const PyDemoResult& d) -> py::object {
            return d.r.outcome ? py::cast(d.r.outcome->latency.device_to_sim_ms.mean) : py::none();
          })
      .def("__repr__", [](const PyDemoResult& d) {
        return fmt::format("DemoResult(ok={}, cubes_in_trays={}, run={}, duration_s={:.1f})",
                           d.r.ok ? "True" : "False", d.r.cubes_in_trays, d.r.demo_run,
                           d.r.duration_s);
      });

  m.def(
      "demo",
      [](const fs::path& out, py::object robot, int cubes, unsigned seed, bool calibrate,
         std::optional<long long> as_built_seed, std::optional<long long> layout_seed,
         int http_port, double robot_speed, double mirror_s, py::object on_line) {
        if (cubes < 1 || cubes > kNumColors) {
          throw py::value_error(fmt::format("demo: cubes={}: must be 1..{}", cubes, kNumColors));
        }
        if (!(robot_speed > 0.0)) {
          throw py::value_error(fmt::format("demo: robot_speed={}: must be > 0", robot_speed));
        }
        const RobotPtr r = robot_or_default(robot);
        session::DemoOptions o;
        o.out_dir = out_folder(out, "demo");
        o.config_path = r->path;
        o.phases.cubes = cubes;
        o.phases.seed = seed;
        o.phases.calibrate = calibrate;
        o.phases.mirror_s = mirror_s;
        o.phases.layout_seed = layout_seed.value_or(-1);
        o.as_built_seed = as_built_seed.value_or(-1);
        o.http_port = http_port;
        o.robot_speed = robot_speed;
        o.bin_dir = py::cast<fs::path>(bin_dir());
        std::atomic<bool> stop{false};
        o.stop = &stop;
        Lines lines(std::move(on_line), stop);
        const session::Say say = lines.say();
        bool interrupted = false;
        auto res = run_off_gil(
            [&] {
              return session::run_demo(r->model, o, say,
                                       [&say](const std::string& l) { say("demo: " + l); });
            },
            [&stop] { stop = true; }, interrupted);
        if (interrupted) throw py::error_already_set();
        lines.rethrow();
        return PyDemoResult{unwrap(std::move(res), ErrorKind::kLink)};
      },
      py::arg("out") = fs::path("scaratwin-out"), py::arg("robot") = py::none(),
      py::arg("cubes") = kNumColors, py::arg("seed") = 7u, py::arg("calibrate") = true,
      py::arg("as_built_seed") = py::none(), py::arg("layout_seed") = py::none(),
      py::arg("http_port") = 0, py::arg("robot_speed") = 1.0, py::arg("mirror_s") = 6.0,
      py::arg("on_line") = py::none(),
      "The paper's procedure, as `scaratwin demo` runs it: the simulator and the emulated "
      "robot started, homing, calibration, mirror, control, prediction and replay; the "
      "database, results.json and the report in `out`. Raises LinkError when a process "
      "cannot be started or reached; a failing phase is in the result (ok False, failure). "
      "Ctrl-C stops the robot and raises KeyboardInterrupt once the report is written.");

  py::class_<PyCalibrationResult>(m, "CalibrationResult",
                                  "What scaratwin.calibrate() identified and wrote.")
      .def_property_readonly("overlay", [](const PyCalibrationResult& c) { return c.r.overlay; })
      .def_property_readonly("pixel_rms",
                             [](const PyCalibrationResult& c) { return c.r.run.fit.pixel_rms; })
      .def_property_readonly("robot_s",
                             [](const PyCalibrationResult& c) { return c.r.run.robot_s; })
      .def_property_readonly("pictures",
                             [](const PyCalibrationResult& c) { return c.r.run.pictures; })
      .def_property_readonly(
          "parameters",
          [](const PyCalibrationResult& c) {
            py::dict d;
            for (int i = 0; i < calib::kParamCount; ++i) {
              const auto& info = calib::param_info(i);
              d[py::str(std::string(info.key))] = py::make_tuple(
                  c.r.run.fit.value[i] / info.to_si, c.r.run.fit.std_error[i] / info.to_si);
            }
            return d;
          },
          "{key: (identified, standard error)} in each key's unit")
      .def_property_readonly(
          "truth",
          [](const PyCalibrationResult& c) {
            py::dict d;
            for (const session::CalibrationParameter& p : c.r.compared) {
              d[py::str(p.key)] = p.truth;
            }
            return d;
          },
          "{key: the emulated robot's true value} (a measuring instrument: the fit never "
          "saw it; NaN where not measured)")
      .def("__repr__", [](const PyCalibrationResult& c) {
        return fmt::format("CalibrationResult(overlay='{}', pixel_rms={:.3f})",
                           c.r.overlay.string(), c.r.run.fit.pixel_rms);
      });

  m.def(
      "calibrate",
      [](const fs::path& out, py::object robot, std::optional<fs::path> overlay, int poses,
         int touch_offs, unsigned seed, std::optional<long long> as_built_seed, double robot_speed,
         py::object on_line) {
        if (poses < 12 || poses > 500) {
          throw py::value_error(fmt::format("calibrate: poses={}: must be 12..500", poses));
        }
        if (touch_offs < 3 || touch_offs > 6) {
          throw py::value_error(fmt::format("calibrate: touch_offs={}: must be 3..6", touch_offs));
        }
        if (!(robot_speed > 0.0)) {
          throw py::value_error(fmt::format("calibrate: robot_speed={}: must be > 0", robot_speed));
        }
        const RobotPtr r = robot_or_default(robot);
        if (r->path.empty()) {
          throw py::value_error(
              "calibrate: the robot must be loaded from a description file (the overlay names "
              "its base): scaratwin.load_robot(PATH)");
        }
        session::CalibrateOptions o;
        o.out_dir = out_folder(out, "calibrate");
        o.config_path = r->path;
        o.overlay = overlay.value_or(fs::path());
        o.marker_poses = poses;
        o.touch_offs = touch_offs;
        o.seed = seed;
        o.as_built_seed = as_built_seed.value_or(-1);
        o.robot_speed = robot_speed;
        o.bin_dir = py::cast<fs::path>(bin_dir());
        RobotModel model = r->model;
        if (o.as_built_seed >= 0)
          model.physical.as_built.seed = static_cast<std::uint64_t>(o.as_built_seed);
        if (is_calibrated(model)) {
          throw py::value_error(
              "calibrate: the robot is a calibrated description; calibrate with its base");
        }
        std::atomic<bool> stop{false};
        o.stop = &stop;
        Lines lines(std::move(on_line), stop);
        const session::Say say = lines.say();
        bool interrupted = false;
        auto res = run_off_gil([&] { return session::run_calibration(model, o, nullptr, say); },
                               [&stop] { stop = true; }, interrupted);
        if (interrupted) throw py::error_already_set();
        lines.rethrow();
        return PyCalibrationResult{unwrap(std::move(res), ErrorKind::kError)};
      },
      py::arg("out") = fs::path("scaratwin-calibration"), py::arg("robot") = py::none(),
      py::arg("overlay") = py::none(), py::arg("poses") = 24, py::arg("touch_offs") = 4,
      py::arg("seed") = 1u, py::arg("as_built_seed") = py::none(), py::arg("robot_speed") = 1.0,
      py::arg("on_line") = py::none(),
      "The calibration routine, as `scaratwin calibrate` runs it on the emulated robot as "
      "built: the overlay (default: <description>.calibrated.toml beside it) written, the "
      "identified parameters returned beside the emulator's truth.");
}

}  // namespace scaratwin::python
