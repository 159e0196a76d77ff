// Loading the robot description (config/scara.toml) into a validated RobotModel. Keys that are
// left out take the paper's defaults; an unknown key, a value of the wrong type or a value out
// of range is an error that names the key, the value and what would be valid.
#pragma once

#include <filesystem>
#include <string_view>

#include "scaratwin/core/result.hpp"
#include "scaratwin/kinematics/robot_model.hpp"

namespace scaratwin {

// Parses TOML text. `source` names the text in error messages (usually the file path).
Result<RobotModel> parse_robot_config(std::string_view toml_text, std::string_view source);

// Reads and parses a file.
Result<RobotModel> load_robot_config(const std::filesystem::path& path);

// The description used when none is given: $SCARATWIN_CONFIG if set, else scara.toml in the
// robot descriptions' folder of data_paths.hpp (the source tree's config/ for an executable run
// from its build tree, <prefix>/share/scaratwin/config/ for an installed one).
std::filesystem::path default_robot_config_path();

// Loads `path`, or the default description when `path` is empty.
Result<RobotModel> load_robot_config_or_default(const std::filesystem::path& path);

}  // namespace scaratwin
