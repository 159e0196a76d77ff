// The fleet's topic layout and payloads on an MQTT broker (docs/fleet.md): one subtree per
// robot under a versioned prefix, in the spirit of VDA 5050.
//
//   scaratwin/v1/<robot>/connection   retained "online" / "offline" (the last will says offline)
//   scaratwin/v1/<robot>/state        JSON twin state, published at a fixed rate
//   scaratwin/v1/<robot>/command      JSON {"id": ..., "statement": "move 0.2 0 0.03"}
//   scaratwin/v1/<robot>/reply        JSON {"id": ..., "ok": true|false, "result"|"error": ...}
//
// Pure: names, checks and JSON text only; the client that talks to the broker is
// fleet/mqtt_bridge.hpp.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>

#include "scaratwin/core/result.hpp"

namespace scaratwin::fleet {

inline constexpr std::string_view kTopicPrefix = "scaratwin/v1";
// A command payload larger than this is refused unread (a statement is one short line).
inline constexpr std::size_t kMaxCommandBytes = 4096;
inline constexpr std::size_t kMaxRobotNameBytes = 64;

// Error codes of the fleet: FleetError (scaratwin/core/error_codes.hpp, 1400..1499).

// The topics of one robot.
struct RobotTopics {
  std::string connection, state, command, reply;
};

// Checks a robot name for use as one topic level: 1..64 bytes of letters, digits, '-', '_'
// and '.'; the error names the name and what is allowed.
Status check_robot_name(std::string_view name);
// The topics of robot `name` (a name check_robot_name accepts).
RobotTopics robot_topics(std::string_view name);

// A broker's address: mqtt://[USER@]HOST[:PORT] (plain, port 1883 by default) or
// mqtts://[USER@]HOST[:PORT][?ca=FILE&cert=FILE&key=FILE&password-file=FILE] (TLS, port 8883 by
// default; the broker's certificate is checked against `ca` (else the system's CAs) and
// against HOST; `cert` and `key` are a client certificate, given together). No user: anonymous.
// A password is never part of the address: a process's arguments are visible to every user of
// the machine (ps), so the URL refuses one; it comes from `password-file` (either scheme) or
// from the environment (kPasswordEnv), read by fleet/mqtt_client.hpp when the client starts.
inline constexpr std::string_view kPasswordEnv = "SCARATWIN_MQTT_PASSWORD";
inline constexpr std::string_view kUsernameEnv = "SCARATWIN_MQTT_USERNAME";
struct BrokerAddress {
  std::string host;
  std::uint16_t port = 1883;
  std::string username;
  std::string password;       // filled from password_file or the environment, never the URL
  std::string password_file;  // as given in the URL
  std::string ca_file, cert_file, key_file;
  bool tls = false;  // mqtts://
};
Result<BrokerAddress> parse_broker_url(std::string_view url);
// The address as printed to the user: scheme, user, host and port (never a password).
std::string broker_label(const BrokerAddress& a);

// A command as it arrived: the id is echoed in the reply as it was sent (a JSON string or
// number, kept as its JSON text).
struct Command {
  std::string id_json;  // e.g. "\"a1\"" or "7"
  std::string statement;
};

// Parses a command payload. Refused: more than kMaxCommandBytes, not a JSON object, no "id"
// (string or number), no "statement" (a string of one line), a "robot" field that is not
// `robot`. The error names the problem; `id_json` is filled in the error case as far as it
// could be read (`null` otherwise), so the reply can still carry it.
Result<Command> parse_command(std::string_view payload, std::string_view robot,
                              std::string* id_json);

// Reply payloads.
std::string reply_ok(std::string_view id_json, std::string_view result);
std::string reply_error(std::string_view id_json, const Error& error);

}  // namespace scaratwin::fleet
