// Loading a workcell file (for example config/two_arms.toml, docs/workcell.md): a list of
// [[robot]] tables, each with a name, the robot description file it uses and its base pose in
// millimetres and degrees. The scene is the first robot's description's. Every error names the
// file and the key; the result has passed validate(Workcell).
#pragma once

#include <filesystem>
#include <string_view>

#include "scaratwin/core/result.hpp"
#include "scaratwin/kinematics/workcell.hpp"

namespace scaratwin {

// Parses TOML text. `source` is the file's path: it names the text in error messages, and the
// robots' description paths are relative to its folder.
Result<Workcell> parse_workcell_config(std::string_view toml_text, std::string_view source);

// Reads and parses a file (ConfigError::kNotFound when it cannot be read).
Result<Workcell> load_workcell_config(const std::filesystem::path& path);

}  // namespace scaratwin
