// The twin database (SQLite) for Python: runs, samples, events, latencies and metrics as numpy
// structured arrays (samples and latencies are views of the records read by the C++ library,
// no per-element copy), or pandas DataFrames with frame=True.
#include <cstddef>

#include <fmt/format.h>
#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>

#include "common.hpp"
#include "scaratwin/hub/twin_db.hpp"

namespace scaratwin::python {
namespace {

static_assert(sizeof(JointRecord) == 7 * sizeof(double), "JointRecord must be 7 packed fields");
static_assert(offsetof(JointRecord, q) == 16 && offsetof(JointRecord, grip_deg) == 48);
static_assert(sizeof(LatencyRecord) == 4 * sizeof(std::int64_t));

struct Db {
  std::unique_ptr<TwinDb> db;
  TwinDb& live() {
    if (!db) throw py::value_error("TwinDb: the database is closed");
    return *db;
  }
};

py::object numpy() { return py::module_::import("numpy"); }

py::object maybe_frame(py::object arr, bool frame) {
  if (!frame) return arr;
  py::object pandas;
  try {
    pandas = py::module_::import("pandas");
  } catch (const py::error_already_set&) {
    throw py::import_error("frame=True needs pandas (apt install python3-pandas)");
  }
  return pandas.attr("DataFrame")(arr);
}

// A structured array over the records of `v` (moved into a capsule that the array keeps).
template <typename T>
py::array view_records(std::vector<T>&& v, const py::dict& spec) {
  auto* owned = new std::vector<T>(std::move(v));
  py::capsule keep(owned, [](void* p) { delete static_cast<std::vector<T>*>(p); });
  py::dtype dt = py::dtype::from_args(spec);
  py::array a(dt, {static_cast<py::ssize_t>(owned->size())}, {static_cast<py::ssize_t>(sizeof(T))},
              owned->data(), keep);
  return a;
}

py::dict record_spec(std::initializer_list<const char*> names, const char* format,
                     std::size_t itemsize) {
  py::list n, f, o;
  std::size_t off = 0;
  for (const char* name : names) {
    n.append(name);
    f.append(format);
    o.append(off);
    off += 8;
  }
  py::dict d;
  d["names"] = n;
  d["formats"] = f;
  d["offsets"] = o;
  d["itemsize"] = itemsize;
  return d;
}

SampleSource parse_source(const std::string& s) {
  for (SampleSource src : {SampleSource::kPlanned, SampleSource::kVirtual, SampleSource::kPhysical,
                           SampleSource::kTruth}) {
    if (s == source_name(src)) return src;
  }
  throw py::value_error(
      fmt::format("samples: source '{}': expected 'planned', 'virtual', 'physical' or 'truth'", s));
}

py::array runs_array(const std::vector<RunInfo>& runs) {
  py::list rows;
  for (const RunInfo& r : runs) {
    rows.append(py::make_tuple(r.id, r.parent, r.ref, r.kind, r.label, r.status, r.started_unix_s,
                               r.duration_s));
  }
  py::list dtype;
  for (const char* f : {"id", "parent", "ref"}) dtype.append(py::make_tuple(f, "i8"));
  for (const char* f : {"kind", "label", "status"}) dtype.append(py::make_tuple(f, "O"));
  for (const char* f : {"started_unix_s", "duration_s"}) dtype.append(py::make_tuple(f, "f8"));
  return numpy().attr("array")(rows, py::arg("dtype") = dtype);
}

}  // namespace

void bind_db(py::module_& m) {
  py::class_<Db>(m, "TwinDb",
                 "The twin database (SQLite, WAL): what every run recorded. Open it while a hub "
                 "writes to it if you like; reads see what was committed.")
      .def(py::init([](const std::filesystem::path& path) {
             auto d = TwinDb::open(path);
             if (!d) raise(ErrorKind::kDatabase, d.error());
             return Db{std::move(*d)};
           }),
           py::arg("path"), "Opens (or creates) the database file.")
      .def_property_readonly(
          "path", [](Db& d) { return d.live().path(); }, "The database file.")
      .def(
          "runs",
          [](Db& d, bool frame) {
            return maybe_frame(runs_array(unwrap(d.live().runs(), ErrorKind::kDatabase)), frame);
          },
          py::arg("frame") = false,
          "Every run: id, parent, ref, kind, label, status, started_unix_s, duration_s.")
      .def(
          "children",
          [](Db& d, std::int64_t parent, bool frame) {
            return maybe_frame(runs_array(unwrap(d.live().children(parent), ErrorKind::kDatabase)),
                               frame);
          },
          py::arg("parent"), py::arg("frame") = false, "The runs of one session (a demo).")
      .def(
          "samples",
          [](Db& d, std::int64_t run, const std::string& source, bool frame) {
            auto v = unwrap(d.live().samples(run, parse_source(source)), ErrorKind::kDatabase);
            py::dict spec =
                record_spec({"t_s", "seq", "d1_m", "q2_rad", "q3_rad", "q4_rad", "grip_deg"}, "f8",
                            sizeof(JointRecord));
            py::list formats = spec["formats"];
            formats[1] = "i8";  // the device sequence number
            return maybe_frame(view_records(std::move(v), spec), frame);
          },
          py::arg("run"), py::arg("source") = "physical", py::arg("frame") = false,
          "Joint samples of a run from one source ('planned', 'virtual', 'physical', 'truth'): "
          "t_s, seq, d1_m, q2_rad, q3_rad, q4_rad, grip_deg.")
      .def(
          "latencies",
          [](Db& d, std::int64_t run, bool frame) {
            auto v = unwrap(d.live().latencies(run), ErrorKind::kDatabase);
            return maybe_frame(view_records(std::move(v), record_spec({"seq", "device_t_us",
                                                                       "hub_rx_us", "sim_apply_us"},
                                                                      "i8", sizeof(LatencyRecord))),
                               frame);
          },
          py::arg("run"), py::arg("frame") = false,
          "Mirror frames of a run: seq, device_t_us, hub_rx_us, sim_apply_us.")
      .def(
          "events",
          [](Db& d, std::int64_t run, bool frame) {
            auto v = unwrap(d.live().events(run), ErrorKind::kDatabase);
            py::list rows;
            for (const auto& [t, text] : v) {
              const std::size_t sep = text.find(": ");
              rows.append(py::make_tuple(t, text.substr(0, sep),
                                         sep == std::string::npos ? "" : text.substr(sep + 2)));
            }
            py::list dtype;
            dtype.append(py::make_tuple("t_s", "f8"));
            dtype.append(py::make_tuple("kind", "O"));
            dtype.append(py::make_tuple("detail", "O"));
            return maybe_frame(numpy().attr("array")(rows, py::arg("dtype") = dtype), frame);
          },
          py::arg("run"), py::arg("frame") = false, "Events of a run: t_s, kind, detail.")
      .def(
          "metrics",
          [](Db& d, std::int64_t run, bool frame) {
            auto v = unwrap(d.live().metrics(run), ErrorKind::kDatabase);
            py::list rows;
            for (const MetricRecord& r : v) rows.append(py::make_tuple(r.name, r.value, r.unit));
            py::list dtype;
            dtype.append(py::make_tuple("name", "O"));
            dtype.append(py::make_tuple("value", "f8"));
            dtype.append(py::make_tuple("unit", "O"));
            return maybe_frame(numpy().attr("array")(rows, py::arg("dtype") = dtype), frame);
          },
          py::arg("run"), py::arg("frame") = false, "Final figures of a run: name, value, unit.")
      .def(
          "export_csv",
          [](Db& d, std::int64_t run, const std::filesystem::path& dir) {
            check(d.live().export_csv(run, dir), ErrorKind::kDatabase);
          },
          py::arg("run"), py::arg("dir"), "Writes every table of one run as CSV files into dir.")
      .def(
          "close", [](Db& d) { d.db.reset(); }, "Commits and closes the file.")
      .def("__enter__", [](py::object self) { return self; })
      .def("__exit__",
           [](Db& d, const py::object&, const py::object&, const py::object&) { d.db.reset(); });
}

}  // namespace scaratwin::python
