// scaratwin._core: the C++ libraries for Python (docs/python.md). The package scaratwin
// re-exports everything; this file holds the exception classes and the argument helpers.
#include <cmath>

#include <fmt/format.h>

#include "common.hpp"

namespace scaratwin::python {
namespace {

// The exception classes, created once at import (the interpreter keeps them alive).
PyObject* g_classes[7] = {};

PyObject* new_class(py::module_& m, const char* name, PyObject* base, const char* doc) {
  const std::string full = fmt::format("scaratwin.{}", name);
  PyObject* cls = PyErr_NewExceptionWithDoc(full.c_str(), doc, base, nullptr);
  if (cls == nullptr) throw py::error_already_set();
  m.add_object(name, py::handle(cls));
  return cls;
}

std::string shape_of(const py::array& a) {
  std::string s = "(";
  for (py::ssize_t i = 0; i < a.ndim(); ++i) {
    s += fmt::format("{}{}", i ? ", " : "", a.shape(i));
  }
  return s + (a.ndim() == 1 ? ",)" : ")");
}

}  // namespace

void register_errors(py::module_& m) {
  PyObject* base = new_class(m, "Error", PyExc_RuntimeError,
                             "Base of every scaratwin error; `code` is the library's error code "
                             "(IkError 1..9, PlanError 10..19, a protocol ER code N as "
                             "200 + N, ...: docs/errors.md).");
  g_classes[static_cast<int>(ErrorKind::kError)] = base;
  const py::tuple config_bases = py::make_tuple(py::handle(base), py::handle(PyExc_ValueError));
  g_classes[static_cast<int>(ErrorKind::kConfig)] =
      new_class(m, "ConfigError", config_bases.ptr(),
                "A robot description that cannot be read or is invalid (names the key).");
  g_classes[static_cast<int>(ErrorKind::kUnreachable)] = new_class(
      m, "UnreachableError", base, "A tool pose without IK solution; `code` is an IkError.");
  g_classes[static_cast<int>(ErrorKind::kPlan)] =
      new_class(m, "PlanError", base, "A planner refused; `code` is a PlanError.");
  g_classes[static_cast<int>(ErrorKind::kLink)] = new_class(
      m, "LinkError", base, "The simulator or the robot cannot be reached, or a link was lost.");
  g_classes[static_cast<int>(ErrorKind::kStatement)] =
      new_class(m, "StatementError", base,
                "A control statement failed; the message is the one the scaratwin command prints.");
  g_classes[static_cast<int>(ErrorKind::kDatabase)] =
      new_class(m, "DatabaseError", base, "The twin database cannot be opened or read.");

  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const BindingError& e) {
      PyObject* cls = g_classes[static_cast<int>(e.kind)];
      py::object inst = py::reinterpret_borrow<py::object>(cls)(e.message);
      inst.attr("code") = e.code;
      PyErr_SetObject(cls, inst.ptr());
    }
  });
}

namespace {
RobotPtr g_default_robot;  // set by scaratwin.default_robot() / set_default_robot()
}  // namespace

void set_default_robot(RobotPtr robot) { g_default_robot = std::move(robot); }

RobotPtr robot_or_default(const py::object& robot) {
  if (!robot.is_none()) return robot.cast<RobotPtr>();
  if (g_default_robot) return g_default_robot;
  // the first call: scaratwin.default_robot() loads the description and sets it
  return py::module_::import("scaratwin").attr("default_robot")().cast<RobotPtr>();
}

// One row given as a list or tuple of `width` Python floats or ints, read without numpy (the
// common single call, fk([d1, q2, q3, q4])); false for anything else.
bool inline_row(const py::handle& obj, int width, Rows& r) {
  PyObject* o = obj.ptr();
  if (!PyList_CheckExact(o) && !PyTuple_CheckExact(o)) return false;
  if (PySequence_Fast_GET_SIZE(o) != width) return false;
  PyObject** items = PySequence_Fast_ITEMS(o);
  for (int j = 0; j < width; ++j) {
    if (PyFloat_CheckExact(items[j])) {
      r.inline_row[j] = PyFloat_AS_DOUBLE(items[j]);
    } else if (PyLong_CheckExact(items[j])) {
      r.inline_row[j] = PyLong_AsDouble(items[j]);
      if (r.inline_row[j] == -1.0 && PyErr_Occurred()) throw py::error_already_set();
    } else {
      return false;
    }
  }
  r.is_inline = true;
  r.single = true;
  r.n = 1;
  return true;
}

Rows rows_of(const py::handle& obj, const char* call, const char* what, int width) {
  Rows r;
  if (width <= 4 && inline_row(obj, width, r)) return r;
  using F64 = py::array_t<double, py::array::c_style>;
  if (F64::check_(obj)) {
    // already float64 and C-contiguous: used as it is
    auto a = py::reinterpret_borrow<F64>(obj);
    if (a.ndim() == 1 && a.shape(0) == width) {
      r.single = true;
      r.n = 1;
      r.array = std::move(a);
      return r;
    }
    if (a.ndim() == 2 && a.shape(1) == width) {
      r.n = a.shape(0);
      r.array = std::move(a);
      return r;
    }
  }
  py::array a = py::array::ensure(obj);
  if (!a) {
    throw py::type_error(fmt::format("{}: {} must be an array of numbers of shape ({},) or (N, {})",
                                     call, what, width, width));
  }
  const char kind = a.dtype().kind();
  if (kind != 'f' && kind != 'i' && kind != 'u') {
    throw py::type_error(
        fmt::format("{}: {} has dtype {}; expected real numbers (float64, or an integer type)",
                    call, what, py::str(a.dtype()).cast<std::string>()));
  }
  if (a.ndim() == 1 && a.shape(0) == width) {
    r.single = true;
    r.n = 1;
  } else if (a.ndim() == 2 && a.shape(1) == width) {
    r.n = a.shape(0);
  } else {
    throw py::value_error(fmt::format("{}: {} must have shape ({},) or (N, {}), got shape {}", call,
                                      what, width, width, shape_of(a)));
  }
  r.array = F64::ensure(a);
  return r;
}

void require_finite(const Rows& rows, const char* call, const char* what, int width) {
  for (py::ssize_t i = 0; i < rows.n; ++i) {
    for (int j = 0; j < width; ++j) {
      if (!std::isfinite(rows.ptr()[i * width + j])) {
        throw py::value_error(
            fmt::format("{}: {}{} has a value that is not finite (NaN or infinite) in column {}",
                        call, what, rows.single ? "" : fmt::format("[{}]", i), j));
      }
    }
  }
}

py::array_t<double> new_rows(py::ssize_t n, bool single, int width) {
  if (single) return py::array_t<double>(width);
  return py::array_t<double>({n, static_cast<py::ssize_t>(width)});
}

}  // namespace scaratwin::python

PYBIND11_MODULE(_core, m) {
  namespace sp = scaratwin::python;
  m.doc() = "The C++ core of scaratwin (import scaratwin, not this module).";
  sp::register_errors(m);
  sp::bind_robot(m);
  sp::bind_trajectory(m);
  sp::bind_twin(m);
  sp::bind_db(m);
  sp::bind_session(m);
}
