// Shared pieces of the Python bindings (scaratwin._core): the exception classes, the robot
// object every call takes, and the conversion of array-like arguments into rows of 4 doubles.
#pragma once

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <array>
#include <chrono>
#include <condition_variable>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>

#include "scaratwin/core/result.hpp"
#include "scaratwin/kinematics/robot_model.hpp"
#include "scaratwin/trajectory/trajectory.hpp"

namespace scaratwin::python {

namespace py = pybind11;

// Which Python exception class an error becomes (all derive from scaratwin.Error).
enum class ErrorKind {
  kError,        // scaratwin.Error
  kConfig,       // scaratwin.ConfigError: a robot description that cannot be used
  kUnreachable,  // scaratwin.UnreachableError: IK has no solution (code = IkError)
  kPlan,         // scaratwin.PlanError: a planner refused (code = PlanError)
  kLink,         // scaratwin.LinkError: the simulator or the robot cannot be reached
  kStatement,    // scaratwin.StatementError: a control statement failed
  kDatabase,     // scaratwin.DatabaseError: the twin database
};

// Thrown by the bindings and turned into the Python exception of `kind` with `code` set.
struct BindingError {
  ErrorKind kind;
  int code;
  std::string message;
};

[[noreturn]] inline void raise(ErrorKind kind, const Error& e) {
  throw BindingError{kind, e.code, e.message};
}

template <typename T>
T unwrap(Result<T> r, ErrorKind kind) {
  if (!r) raise(kind, r.error());
  return std::move(r).value();
}

inline void check(const Status& s, ErrorKind kind) {
  if (!s) raise(kind, s.error());
}

void register_errors(py::module_& m);

// A loaded robot description (immutable once loaded).
struct Robot {
  RobotModel model;
  std::string path;  // the file it came from ("" for the paper's built-in robot)
};
using RobotPtr = std::shared_ptr<Robot>;  // immutable once loaded (no setters are bound)

// The robot of a call: `robot` itself, or scaratwin.default_robot() when it is None.
RobotPtr robot_or_default(const py::object& robot);
void set_default_robot(RobotPtr robot);

// Rows of 4 doubles from an array-like of shape (4,) or (N, 4) with a real dtype (float or
// integer). Raises TypeError (dtype) or ValueError (shape) naming `call` and `what`.
struct Rows {
  py::array_t<double, py::array::c_style> array;  // unused when the row is held inline
  std::array<double, 4> inline_row{};             // a list or tuple of 4 numbers
  bool is_inline = false;
  py::ssize_t n = 0;
  bool single = false;  // the input was one (4,) row
  const double* ptr() const {
    if (is_inline) return inline_row.data();
    return n > 0 ? array.data() : nullptr;  // a default array_t is an empty array, not null
  }
};
Rows rows_of(const py::handle& obj, const char* call, const char* what, int width = 4);

// Raises ValueError when a value is NaN or infinite, naming the first such row.
void require_finite(const Rows& rows, const char* call, const char* what, int width = 4);

// A new float64 array of shape (n, width), or (width,) when `single`.
py::array_t<double> new_rows(py::ssize_t n, bool single, int width = 4);

// The C++ trajectory inside a scaratwin.Trajectory (raises TypeError for anything else).
const JointTrajectory& trajectory_of(const py::handle& obj);

// Runs `f` on a worker thread with the GIL released, while the calling thread checks Python's
// signals every 50 ms. On Ctrl-C, `on_interrupt()` runs once (it stops the robot, so that `f`
// ends soon) and `interrupted` turns true; the KeyboardInterrupt stays pending as this
// thread's Python error, for the caller to raise (py::error_already_set) once it has tidied
// up. Returns f's result.
template <typename F, typename G>
auto run_off_gil(F&& f, G&& on_interrupt, bool& interrupted) {
  using R = decltype(f());
  std::optional<R> result;
  py::gil_scoped_release nogil;
  std::mutex mu;
  std::condition_variable cv;
  bool done = false;
  std::thread worker([&] {
    R r = f();
    std::lock_guard<std::mutex> lock(mu);
    result.emplace(std::move(r));
    done = true;
    cv.notify_all();
  });
  std::unique_lock<std::mutex> lock(mu);
  while (!cv.wait_for(lock, std::chrono::milliseconds(50), [&] { return done; })) {
    if (interrupted) continue;
    lock.unlock();
    {
      py::gil_scoped_acquire gil;
      interrupted = PyErr_CheckSignals() != 0;
    }
    if (interrupted) on_interrupt();
    lock.lock();
  }
  lock.unlock();
  worker.join();
  return std::move(*result);
}

void bind_robot(py::module_& m);
void bind_trajectory(py::module_& m);
void bind_twin(py::module_& m);
void bind_db(py::module_& m);
void bind_session(py::module_& m);

}  // namespace scaratwin::python
