#include "scaratwin/config/robot_config.hpp"

#include <unistd.h>

#include <cmath>
#include <cstdlib>
#include <fstream>
#include <optional>
#include <set>
#include <sstream>
#include <string>

#include <fmt/format.h>

#include <toml++/toml.h>

#include "scaratwin/config/data_paths.hpp"
#include "scaratwin/core/units.hpp"
#include "toml_text.hpp"

namespace scaratwin {
namespace {

// Walks one TOML table, remembering which keys were read so that the rest can be reported as
// unknown. Errors are collected as the first one found.
class TableReader {
 public:
  TableReader(const toml::table* table, std::string path, std::string* error)
      : table_(table), path_(std::move(path)), error_(error) {}

  bool present() const { return table_ != nullptr; }

  // Reads a number into `out` (scaled by `scale`) if the key exists.
  void number(const char* key, double& out, double scale = 1.0) {
    const toml::node* n = get(key);
    if (n == nullptr) return;
    if (auto v = n->value<double>(); v && n->is_number()) {
      if (!std::isfinite(*v)) {
        fail(fmt::format("{} = {}: must be a finite number", name(key), *v));
        return;
      }
      out = *v * scale;
    } else {
      fail(fmt::format("{}: expected a number, found {}", name(key), type_of(*n)));
    }
  }

  void integer(const char* key, int& out, int lo, int hi) {
    const toml::node* n = get(key);
    if (n == nullptr) return;
    auto v = n->value<int64_t>();
    if (!n->is_integer() || !v) {
      fail(fmt::format("{}: expected an integer, found {}", name(key), type_of(*n)));
    } else if (*v < lo || *v > hi) {
      fail(fmt::format("{} = {}: must be between {} and {}", name(key), *v, lo, hi));
    } else {
      out = static_cast<int>(*v);
    }
  }

  void string(const char* key, std::string& out) {
    const toml::node* n = get(key);
    if (n == nullptr) return;
    if (auto v = n->value<std::string>(); v && n->is_string()) {
      out = *v;
    } else {
      fail(fmt::format("{}: expected a string, found {}", name(key), type_of(*n)));
    }
  }

  // Reads an array of exactly N numbers.
  template <size_t N>
  void numbers(const char* key, std::array<double, N>& out, double scale = 1.0) {
    const toml::node* n = get(key);
    if (n == nullptr) return;
    const toml::array* arr = n->as_array();
    if (arr == nullptr || arr->size() != N) {
      fail(fmt::format("{}: expected an array of {} numbers", name(key), N));
      return;
    }
    std::array<double, N> tmp{};
    for (size_t i = 0; i < N; ++i) {
      auto v = (*arr)[i].value<double>();
      if (!v || !(*arr)[i].is_number() || !std::isfinite(*v)) {
        fail(fmt::format("{}[{}]: expected a finite number", name(key), i));
        return;
      }
      tmp[i] = *v * scale;
    }
    out = tmp;
  }

  // Reads an array of exactly N integers, each in [lo, hi].
  template <size_t N>
  void integers(const char* key, std::array<int, N>& out, int lo, int hi) {
    const toml::node* n = get(key);
    if (n == nullptr) return;
    const toml::array* arr = n->as_array();
    if (arr == nullptr || arr->size() != N) {
      fail(fmt::format("{}: expected an array of {} integers", name(key), N));
      return;
    }
    std::array<int, N> tmp{};
    for (size_t i = 0; i < N; ++i) {
      auto v = (*arr)[i].value<int64_t>();
      if (!(*arr)[i].is_integer() || !v) {
        fail(fmt::format("{}[{}]: expected an integer", name(key), i));
        return;
      }
      if (*v < lo || *v > hi) {
        fail(fmt::format("{}[{}] = {}: must be between {} and {}", name(key), i, *v, lo, hi));
        return;
      }
      tmp[i] = static_cast<int>(*v);
    }
    out = tmp;
  }

  TableReader sub(const char* key) {
    const toml::node* n = get(key);
    if (n != nullptr && !n->is_table()) {
      fail(fmt::format("{}: expected a table, found {}", name(key), type_of(*n)));
      return TableReader(nullptr, name(key), error_);
    }
    return TableReader(n ? n->as_table() : nullptr, name(key), error_);
  }

  // Reports the first key of this table that nobody read.
  void reject_unknown(std::string_view valid) {
    if (table_ == nullptr) return;
    for (const auto& [k, v] : *table_) {
      if (!seen_.count(std::string(k.str()))) {
        fail(fmt::format("{}: unknown key (valid keys: {})", name(std::string(k.str()).c_str()),
                         valid));
        return;
      }
    }
  }

  void fail(std::string message) {
    if (error_->empty()) *error_ = std::move(message);
  }

 private:
  const toml::node* get(const char* key) {
    seen_.insert(key);
    return table_ ? table_->get(key) : nullptr;
  }
  std::string name(const char* key) const {
    return path_.empty() ? std::string(key) : path_ + "." + key;
  }
  static std::string type_of(const toml::node& n) { return config_detail::type_of(n); }

  const toml::table* table_;
  std::string path_;
  std::string* error_;
  std::set<std::string> seen_;
};

void read_stepper(TableReader t, const char* unit_key, StepperAxis& axis, double* coupling) {
  t.number(unit_key, axis.steps_per_unit);
  t.number("max_speed_steps_s", axis.max_speed_steps_s);
  t.number("max_accel_steps_s2", axis.max_accel_steps_s2);
  if (coupling != nullptr) {
    t.number("coupling_steps_per_j2_step", *coupling);
    t.reject_unknown(
        fmt::format("{}, max_speed_steps_s, max_accel_steps_s2, "
                    "coupling_steps_per_j2_step",
                    unit_key));
  } else {
    t.reject_unknown(fmt::format("{}, max_speed_steps_s, max_accel_steps_s2", unit_key));
  }
}

void read_servo(TableReader t, ServoSpec& s, double* open_deg, double* closed_deg) {
  t.number("min_deg", s.min_deg);
  t.number("max_deg", s.max_deg);
  t.number("pulse_min_us", s.pulse_min_us);
  t.number("pulse_max_us", s.pulse_max_us);
  t.number("max_speed_deg_s", s.max_speed_deg_s);
  if (open_deg != nullptr) {
    t.number("open_deg", *open_deg);
    t.number("closed_deg", *closed_deg);
    t.reject_unknown(
        "min_deg, max_deg, pulse_min_us, pulse_max_us, max_speed_deg_s, open_deg, closed_deg");
  } else {
    t.reject_unknown("min_deg, max_deg, pulse_min_us, pulse_max_us, max_speed_deg_s");
  }
}

void read_physical(TableReader& top, PhysicalModel& p) {
  {
    TableReader d = top.sub("drive");
    d.number("supply_v", p.drive.supply_v);
    StepperDrive& m = p.drive.motor;
    d.number("holding_torque_nm", m.holding_torque_nm);
    d.number("rated_current_a", m.rated_current_a);
    d.number("current_a", m.current_a);
    d.number("resistance_ohm", m.resistance_ohm);
    d.number("inductance_mh", m.inductance_h, 1e-3);
    d.number("rotor_inertia_gcm2", m.rotor_inertia_kgm2, 1e-7);
    d.number("detent_torque_nm", m.detent_torque_nm);
    d.number("friction_nm", m.friction_nm);
    d.number("viscous_nms", m.viscous_nms);
    d.integer("full_steps_per_rev", m.full_steps_per_rev, 4, 1000);
    d.integer("microsteps", m.microsteps, 1, 256);
    d.numbers("stiffness", p.drive.stiffness);
    d.numbers("damping", p.drive.damping);
    d.reject_unknown(
        "supply_v, holding_torque_nm, rated_current_a, current_a, resistance_ohm, "
        "inductance_mh, rotor_inertia_gcm2, detent_torque_nm, friction_nm, viscous_nms, "
        "full_steps_per_rev, microsteps, stiffness, damping");
    const double positive[] = {p.drive.supply_v,     m.holding_torque_nm,  m.rated_current_a,
                               m.current_a,          m.resistance_ohm,     m.inductance_h,
                               m.rotor_inertia_kgm2, p.drive.stiffness[0], p.drive.stiffness[1],
                               p.drive.stiffness[2]};
    for (double v : positive) {
      if (!(v > 0.0)) {
        d.fail(
            fmt::format("drive: {} is not positive: supply, torque, currents, resistance, "
                        "inductance, inertia and stiffness must be > 0",
                        v));
        break;
      }
    }
    if (m.current_a > m.rated_current_a * 1.5) {
      d.fail(fmt::format("drive.current_a = {} A: more than 1.5 x the rated {} A", m.current_a,
                         m.rated_current_a));
    }
  }
  {
    TableReader a = top.sub("as_built");
    int seed = static_cast<int>(p.as_built.seed);
    a.integer("seed", seed, 0, 2147483647);
    p.as_built.seed = static_cast<std::uint64_t>(seed);
    const auto& keys = as_built_keys();
    std::string valid;
    for (const AsBuiltKey& k : keys) valid += (valid.empty() ? "" : ", ") + std::string(k.key);
    TableReader tol = a.sub("tolerance");
    TableReader val = a.sub("values");
    for (int i = 0; i < kAsBuiltCount; ++i) {
      const std::string key(keys[i].key);
      double t = p.as_built.tolerance[i] / keys[i].to_si;
      tol.number(key.c_str(), t);
      if (t < 0.0) tol.fail(fmt::format("as_built.tolerance.{} = {}: must be >= 0", key, t));
      p.as_built.tolerance[i] = t * keys[i].to_si;
      double v = std::nan("");
      val.number(key.c_str(), v);
      if (!std::isnan(v)) {
        if (keys[i].magnitude && v < 0.0) {
          val.fail(fmt::format("as_built.values.{} = {}: a dead band must be >= 0", key, v));
        }
        p.as_built.fixed[i] = true;
        p.as_built.value[i] = v * keys[i].to_si;
      }
    }
    tol.reject_unknown(valid);
    val.reject_unknown(valid);
    a.reject_unknown("seed, tolerance, values");
  }
}

// What `scaratwin calibrate` identified (an overlay's [calibration], docs/calibration.md):
// the links and the joint map as deviations from the base description, the webcam absolute.
void read_calibration(TableReader& top, RobotModel& m) {
  TableReader c = top.sub("calibration");
  if (!c.present()) return;
  std::string text;
  c.string("date", text);
  c.string("robot", text);
  int count = 0;
  c.integer("pattern_points", count, 0, 1000000);
  c.integer("marker_views", count, 0, 1000000);
  c.integer("marker_points", count, 0, 1000000);
  c.integer("outliers", count, 0, 1000000);
  c.integer("touch_offs", count, 0, 1000000);
  double x = 0.0;
  c.number("pixel_rms", x);
  c.number("touch_rms_mm", x);
  c.number("fit_s", x);
  constexpr double kMm = 1e-3, kPct = 1e-2, kRad = 1.0 / kDegPerRad;
  JointCalibration& j = m.calibration;
  struct Key {
    const char* key;
    double* field;
    double to_si;
  };
  const Key keys[] = {
      {"a2_mm", &m.dh[1].a_m, kMm},
      {"a3_mm", &m.dh[2].a_m, kMm},
      {"jaw_offset_mm", &m.dh[3].a_m, kMm},
      {"z_offset_mm", &j.z_offset_m, kMm},
      {"z_scale_percent", &j.z_scale, kPct},
      {"j2_zero_deg", &j.j2_zero_rad, kRad},
      {"j3_zero_deg", &j.j3_zero_rad, kRad},
      {"wrist_offset_deg", &j.wrist_offset_rad, kRad},
      {"wrist_gain_percent", &j.wrist_gain, kPct},
      {"j2_backlash_deg", &j.backlash[1], kRad},
      {"j3_backlash_deg", &j.backlash[2], kRad},
  };
  TableReader id = c.sub("identified");
  std::string valid;
  std::array<double, kNumJoints> nominal_a_m{};
  for (int i = 0; i < kNumJoints; ++i) nominal_a_m[i] = m.dh[i].a_m;
  for (const Key& k : keys) {
    std::array<double, 2> v{std::nan(""), 0.0};  // value, standard error
    id.numbers(k.key, v);
    if (!std::isnan(v[0])) *k.field += v[0] * k.to_si;
    valid += std::string(k.key) + ", ";
  }
  // what the links gained, so that the nominal description stays known
  for (int i = 0; i < kNumJoints; ++i) j.a_delta_m[i] += m.dh[i].a_m - nominal_a_m[i];
  // the camera's adjustments are recorded for the reader; the webcam table below is absolute
  static constexpr const char* kCamera[] = {
      "camera_dx_mm",  "camera_dy_mm",  "camera_dz_mm",         "camera_rx_deg",
      "camera_ry_deg", "camera_rz_deg", "camera_focal_percent", "camera_k1"};
  for (const char* k : kCamera) {
    std::array<double, 2> v{};
    id.numbers(k, v);
    valid += std::string(k) + ", ";
  }
  id.reject_unknown(valid.substr(0, valid.size() - 2));
  TableReader w = c.sub("webcam");
  if (w.present()) {
    WebcamCalibration& cam = m.webcam;
    cam.valid = true;
    w.numbers("pos_m", cam.pos_m);
    w.numbers("r_bc", cam.r_bc);
    w.number("f_px", cam.f_px);
    w.number("cx_px", cam.cx_px);
    w.number("cy_px", cam.cy_px);
    w.number("k1", cam.k1);
    w.number("k2", cam.k2);
    w.integer("width_px", cam.width_px, 16, 8192);
    w.integer("height_px", cam.height_px, 16, 8192);
    w.reject_unknown("pos_m, r_bc, f_px, cx_px, cy_px, k1, k2, width_px, height_px");
    if (!(cam.f_px > 0.0))
      w.fail(fmt::format("calibration.webcam.f_px = {}: must be > 0", cam.f_px));
  }
  c.reject_unknown(
      "date, robot, pattern_points, marker_views, marker_points, outliers, touch_offs, pixel_rms, "
      "touch_rms_mm, fit_s, identified, webcam");
}

}  // namespace

Result<RobotModel> parse_robot_config(std::string_view toml_text, std::string_view source) {
  auto parsed = config_detail::parse_toml(toml_text, source);
  if (!parsed) return parsed.error();
  const toml::table& root = *parsed;
  std::string error;
  TableReader top(&root, "", &error);
  // an overlay (written by `scaratwin calibrate`): the base description it refines, then what
  // calibration identified; nothing else
  if (const toml::node* base = root.get("base")) {
    const std::optional<std::string> ref = base->value<std::string>();
    if (!ref)
      return Error{ConfigError::kInvalid,
                   fmt::format("{}: base: expected the path of a robot description", source)};
    std::filesystem::path path(*ref);
    if (path.is_relative()) path = std::filesystem::path(source).parent_path() / path;
    if (path == std::filesystem::path(source)) {
      return Error{ConfigError::kInvalid, fmt::format("{}: base names the overlay itself", source)};
    }
    // a chain of overlays is fine; a circle of them is not
    thread_local int depth = 0;
    if (depth >= 8)
      return Error{ConfigError::kInvalid,
                   fmt::format("{}: base: more than 8 overlays deep (a circle?)", source)};
    ++depth;
    auto base_model = load_robot_config(path);
    --depth;
    if (!base_model) {
      return Error{ConfigError::kInvalid,
                   fmt::format("{}: its base description: {}", source, base_model.error().message)};
    }
    RobotModel m = std::move(base_model).value();
    std::string unused;
    top.string("base", unused);
    read_calibration(top, m);
    top.reject_unknown("base, calibration (an overlay refines its base description only)");
    if (!error.empty()) return Error{ConfigError::kInvalid, fmt::format("{}: {}", source, error)};
    if (Status s = validate(m); !s)
      return Error{ConfigError::kInvalid, fmt::format("{}: {}", source, s.error().message)};
    return m;
  }
  RobotModel m = paper_robot();
  top.string("name", m.name);

  {
    TableReader dh = top.sub("dh");
    for (int i = 0; i < kNumJoints; ++i) {
      static constexpr const char* kJ[] = {"j1", "j2", "j3", "j4"};
      TableReader row = dh.sub(kJ[i]);
      std::string type = m.dh[i].type == JointType::kPrismatic ? "prismatic" : "revolute";
      row.string("type", type);
      if (type == "prismatic") {
        m.dh[i].type = JointType::kPrismatic;
      } else if (type == "revolute") {
        m.dh[i].type = JointType::kRevolute;
      } else {
        row.fail(fmt::format("dh.{}.type = \"{}\": expected \"prismatic\" or \"revolute\"", kJ[i],
                             type));
      }
      row.number("theta_deg", m.dh[i].theta_rad, 1.0 / kDegPerRad);
      row.number("d_m", m.dh[i].d_m);
      row.number("a_m", m.dh[i].a_m);
      row.number("alpha_deg", m.dh[i].alpha_rad, 1.0 / kDegPerRad);
      row.reject_unknown("type, theta_deg, d_m, a_m, alpha_deg");
    }
    dh.reject_unknown("j1, j2, j3, j4");
  }
  {
    TableReader lim = top.sub("limits");
    std::array<double, 2> r{m.limits[0].min, m.limits[0].max};
    lim.numbers("j1_m", r);
    m.limits[0] = {r[0], r[1]};
    static constexpr const char* kK[] = {"j2_deg", "j3_deg", "j4_deg"};
    for (int i = 1; i < kNumJoints; ++i) {
      r = {m.limits[i].min, m.limits[i].max};
      lim.numbers(kK[i - 1], r, 1.0 / kDegPerRad);
      m.limits[i] = {r[0], r[1]};
    }
    lim.reject_unknown("j1_m, j2_deg, j3_deg, j4_deg");
  }
  {
    TableReader home = top.sub("home");
    home.number("d1_m", m.home[0]);
    home.number("q2_deg", m.home[1], 1.0 / kDegPerRad);
    home.number("q3_deg", m.home[2], 1.0 / kDegPerRad);
    home.number("q4_deg", m.home[3], 1.0 / kDegPerRad);
    home.reject_unknown("d1_m, q2_deg, q3_deg, q4_deg");
  }
  {
    TableReader motors = top.sub("motors");
    read_stepper(motors.sub("z"), "steps_per_m", m.motors.z, nullptr);
    read_stepper(motors.sub("j2"), "steps_per_rad", m.motors.j2, nullptr);
    read_stepper(motors.sub("j3"), "steps_per_rad", m.motors.j3, &m.motors.j3_per_j2_coupling);
    motors.reject_unknown("z, j2, j3");
  }
  {
    TableReader servos = top.sub("servos");
    read_servo(servos.sub("wrist"), m.motors.wrist, nullptr, nullptr);
    read_servo(servos.sub("gripper"), m.motors.gripper, &m.motors.gripper_open_deg,
               &m.motors.gripper_closed_deg);
    servos.reject_unknown("wrist, gripper");
  }
  {
    TableReader end = top.sub("endstops");
    end.number("z_m", m.endstops.closes_at[0]);
    end.number("j2_deg", m.endstops.closes_at[1], 1.0 / kDegPerRad);
    end.number("j3_deg", m.endstops.closes_at[2], 1.0 / kDegPerRad);
    end.integers("homing_dir", m.endstops.homing_dir, -1, 1);
    end.integer("pulloff_steps", m.endstops.pulloff_steps, 1, 1000);
    end.reject_unknown("z_m, j2_deg, j3_deg, homing_dir, pulloff_steps");
  }
  {
    TableReader scene = top.sub("scene");
    scene.number("table_z_m", m.scene.table_z_m);
    scene.number("cube_size_m", m.scene.cube_size_m);
    scene.number("grasp_z_m", m.scene.grasp_z_m);
    scene.number("approach_height_m", m.scene.approach_height_m);
    TableReader trays = scene.sub("trays");
    for (int c = 0; c < kNumColors; ++c) {
      TableReader tray = trays.sub(color_name(static_cast<CubeColor>(c)));
      tray.number("x_m", m.scene.trays[c].x_m);
      tray.number("y_m", m.scene.trays[c].y_m);
      tray.number("size_m", m.scene.trays[c].size_m);
      tray.reject_unknown("x_m, y_m, size_m");
    }
    trays.reject_unknown("red, green, blue");
    TableReader cam = scene.sub("camera");
    cam.numbers("pos_m", m.scene.camera.pos_m);
    cam.numbers("look_at_m", m.scene.camera.look_at_m);
    cam.number("fovy_deg", m.scene.camera.fovy_deg);
    cam.integer("width_px", m.scene.camera.width_px, 16, 4096);
    cam.integer("height_px", m.scene.camera.height_px, 16, 4096);
    cam.number("roll_deg", m.scene.camera.roll_rad, 1.0 / kDegPerRad);
    cam.reject_unknown("pos_m, look_at_m, fovy_deg, width_px, height_px, roll_deg");
    TableReader pat = scene.sub("pattern");
    PatternModel& pt = m.scene.pattern;
    pat.number("x_m", pt.x_m);
    pat.number("y_m", pt.y_m);
    pat.number("yaw_deg", pt.yaw_rad, 1.0 / kDegPerRad);
    pat.number("tag_size_m", pt.tag_size_m);
    pat.number("spacing_m", pt.spacing_m);
    pat.integer("columns", pt.columns, 1, 64);
    pat.integer("rows", pt.rows, 1, 64);
    pat.number("thickness_m", pt.thickness_m);
    pat.reject_unknown("x_m, y_m, yaw_deg, tag_size_m, spacing_m, columns, rows, thickness_m");
    scene.reject_unknown(
        "table_z_m, cube_size_m, grasp_z_m, approach_height_m, trays, camera, pattern");
  }
  read_physical(top, m.physical);
  top.reject_unknown("name, dh, limits, home, motors, servos, endstops, scene, drive, as_built");
  if (!error.empty()) return Error{ConfigError::kInvalid, fmt::format("{}: {}", source, error)};
  if (Status s = validate(m); !s)
    return Error{ConfigError::kInvalid, fmt::format("{}: {}", source, s.error().message)};
  return m;
}

Result<RobotModel> load_robot_config(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    return Error{ConfigError::kNotFound,
                 fmt::format("cannot read robot description '{}': no such file or not "
                             "readable (pass --config FILE or set SCARATWIN_CONFIG)",
                             path.string())};
  }
  std::stringstream ss;
  ss << in.rdbuf();
  return parse_robot_config(ss.str(), path.string());
}

std::filesystem::path default_robot_config_path() {
  if (const char* env = std::getenv("SCARATWIN_CONFIG"); env != nullptr && *env != '\0') {
    return env;
  }
  return data_paths().config_dir / "scara.toml";
}

Result<RobotModel> load_robot_config_or_default(const std::filesystem::path& path) {
  if (path.empty()) {
    const std::filesystem::path def = default_robot_config_path();
    std::error_code ec;
    const char* env = std::getenv("SCARATWIN_CONFIG");
    if ((env == nullptr || *env == '\0') && !std::filesystem::exists(def, ec)) {
      return Error{ConfigError::kNotFound, missing_data_message("robot description", def) +
                                               " (or pass --config FILE, or set SCARATWIN_CONFIG)"};
    }
    return load_robot_config(def);
  }
  return load_robot_config(path);
}

}  // namespace scaratwin
