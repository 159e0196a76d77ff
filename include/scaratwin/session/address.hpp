// A network address as the options give it: "HOST:PORT".
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

namespace scaratwin::session {

// The host before the last ':' (not empty) and a port of 1..65535 in decimal digits with
// nothing after them; nullopt for anything else.
struct HostPort {
  std::string host;
  std::uint16_t port = 0;
};
std::optional<HostPort> parse_host_port(std::string_view text);

}  // namespace scaratwin::session
