// The workcell file loader (see workcell_config.hpp).
#include "scaratwin/config/workcell_config.hpp"

#include <cmath>
#include <fstream>
#include <optional>
#include <sstream>
#include <string>

#include <fmt/format.h>

#include <toml++/toml.h>

#include "scaratwin/config/robot_config.hpp"
#include "scaratwin/core/units.hpp"
#include "toml_text.hpp"

namespace scaratwin {
namespace {

constexpr const char* kRobotKeys = "name, description, x_mm, y_mm, z_mm, yaw_deg";

Error invalid(std::string_view source, const std::string& message) {
  return Error{ConfigError::kInvalid, fmt::format("{}: {}", source, message)};
}

using config_detail::type_of;

}  // namespace

Result<Workcell> parse_workcell_config(std::string_view toml_text, std::string_view source) {
  auto parsed = config_detail::parse_toml(toml_text, source);
  if (!parsed) return parsed.error();
  const toml::table& root = *parsed;
  for (const auto& [k, v] : root) {
    if (k.str() != "robot") {
      return invalid(source, fmt::format("{}: unknown key (valid keys: robot, an array of "
                                         "[[robot]] tables)",
                                         k.str()));
    }
  }
  const toml::node* robots_node = root.get("robot");
  const toml::array* robots = robots_node ? robots_node->as_array() : nullptr;
  if (robots_node != nullptr && robots == nullptr) {
    return invalid(
        source, fmt::format("robot: expected [[robot]] tables, found {}", type_of(*robots_node)));
  }
  if (robots == nullptr || robots->empty()) {
    return invalid(source, "no [[robot]] table: a workcell needs at least one robot");
  }
  const std::filesystem::path folder = std::filesystem::path(source).parent_path();
  Workcell w;
  for (std::size_t i = 0; i < robots->size(); ++i) {
    const toml::table* t = (*robots)[i].as_table();
    const std::string at = fmt::format("robot[{}]", i);
    if (t == nullptr) {
      return invalid(source,
                     fmt::format("{}: expected a table, found {}", at, type_of((*robots)[i])));
    }
    for (const auto& [k, v] : *t) {
      const std::string_view key = k.str();
      if (key != "name" && key != "description" && key != "x_mm" && key != "y_mm" &&
          key != "z_mm" && key != "yaw_deg") {
        return invalid(source,
                       fmt::format("{}.{}: unknown key (valid keys: {})", at, key, kRobotKeys));
      }
    }
    RobotInstance r;
    // strings: both required
    for (const char* key : {"name", "description"}) {
      const toml::node* n = t->get(key);
      if (n == nullptr) {
        return invalid(source, fmt::format("{}.{}: missing (every robot has a name and a "
                                           "description file)",
                                           at, key));
      }
      const std::optional<std::string> s = n->is_string() ? n->value<std::string>() : std::nullopt;
      if (!s) {
        return invalid(source,
                       fmt::format("{}.{}: expected a string, found {}", at, key, type_of(*n)));
      }
      (std::string_view(key) == "name" ? r.name : r.description_file) = *s;
    }
    // the base pose: millimetres and degrees at the edge, SI inside
    struct Num {
      const char* key;
      double* out;
      double to_si;
    };
    const Num nums[] = {{"x_mm", &r.base.x_m, 1e-3},
                        {"y_mm", &r.base.y_m, 1e-3},
                        {"z_mm", &r.base.z_m, 1e-3},
                        {"yaw_deg", &r.base.yaw_rad, 1.0 / kDegPerRad}};
    for (const Num& num : nums) {
      const toml::node* n = t->get(num.key);
      if (n == nullptr) continue;  // 0
      const std::optional<double> v = n->is_number() ? n->value<double>() : std::nullopt;
      if (!v || !std::isfinite(*v)) {
        return invalid(source, fmt::format("{} ('{}').{}: expected a finite number, found {}", at,
                                           r.name, num.key, type_of(*n)));
      }
      if (std::string_view(num.key) == "yaw_deg" && !(*v >= -360.0 && *v <= 360.0)) {
        return invalid(
            source, fmt::format("{} ('{}').yaw_deg = {}: must be in [-360, 360]", at, r.name, *v));
      }
      *num.out = *v * num.to_si;
    }
    std::filesystem::path desc(r.description_file);
    if (desc.is_relative()) desc = folder / desc;
    auto model = load_robot_config(desc);
    if (!model) {
      return Error{model.error().code, fmt::format("{}: {} ('{}').description: {}", source, at,
                                                   r.name, model.error().message)};
    }
    r.model = std::move(model).value();
    r.description_file = desc.string();
    if (i == 0) w.scene = r.model.scene;
    w.robots.push_back(std::move(r));
  }
  if (Status s = validate(w); !s) {
    return Error{s.error().code, fmt::format("{}: {}", source, s.error().message)};
  }
  return w;
}

Result<Workcell> load_workcell_config(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    return Error{
        ConfigError::kNotFound,
        fmt::format("cannot read workcell file '{}': no such file or not readable", path.string())};
  }
  std::stringstream ss;
  ss << in.rdbuf();
  return parse_workcell_config(ss.str(), path.string());
}

}  // namespace scaratwin
