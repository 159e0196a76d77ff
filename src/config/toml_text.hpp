// What both description loaders (robot_config.cpp, workcell_config.cpp) do with TOML text: parse
// it with errors that name the file, line and column, and name a node's type in messages.
#pragma once

#include <sstream>
#include <string>
#include <string_view>

#include <fmt/format.h>

#include <toml++/toml.h>

#include "scaratwin/core/error_codes.hpp"
#include "scaratwin/core/result.hpp"

namespace scaratwin::config_detail {

inline Result<toml::table> parse_toml(std::string_view text, std::string_view source) {
  try {
    return toml::parse(text, std::string(source));
  } catch (const toml::parse_error& e) {
    return Error{ConfigError::kInvalid, fmt::format("{}:{}:{}: {}", source, e.source().begin.line,
                                                    e.source().begin.column, e.description())};
  }
}

inline std::string type_of(const toml::node& n) {
  std::ostringstream s;
  s << n.type();
  return s.str();
}

}  // namespace scaratwin::config_detail
