#include "scaratwin/fleet/topics.hpp"

#include <charconv>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

namespace scaratwin::fleet {

Status check_robot_name(std::string_view name) {
  if (name.empty() || name.size() > kMaxRobotNameBytes) {
    return Error{kBadRobotName,
                 fmt::format("robot name '{}': give 1 to {} characters", name, kMaxRobotNameBytes)};
  }
  for (const char c : name) {
    const bool ok = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') ||
                    c == '-' || c == '_' || c == '.';
    if (!ok) {
      return Error{kBadRobotName,
                   fmt::format("robot name '{}': '{}' is not allowed in a topic level (use "
                               "letters, digits, '-', '_' and '.')",
                               name, c)};
    }
  }
  return Ok{};
}

RobotTopics robot_topics(std::string_view name) {
  const std::string base = fmt::format("{}/{}/", kTopicPrefix, name);
  return {base + "connection", base + "state", base + "command", base + "reply"};
}

Result<BrokerAddress> parse_broker_url(std::string_view url) {
  constexpr std::string_view kPlain = "mqtt://";
  constexpr std::string_view kTls = "mqtts://";
  const auto bad = [&](std::string_view why) {
    return Error{kBadUrl, fmt::format("--mqtt '{}': {} (expected mqtt://[USER@]HOST[:PORT] or "
                                      "mqtts://[USER@]HOST[:PORT][?ca=FILE&cert=FILE&key=FILE])",
                                      url, why)};
  };
  BrokerAddress a;
  std::string_view rest;
  if (url.substr(0, kTls.size()) == kTls) {
    a.tls = true;
    a.port = 8883;
    rest = url.substr(kTls.size());
  } else if (url.substr(0, kPlain.size()) == kPlain) {
    rest = url.substr(kPlain.size());
  } else {
    return bad("not an mqtt:// or mqtts:// address");
  }
  std::string_view query;
  if (const size_t q = rest.find('?'); q != std::string_view::npos) {
    query = rest.substr(q + 1);
    rest = rest.substr(0, q);
  }
  if (!rest.empty() && rest.back() == '/') rest.remove_suffix(1);
  if (const size_t at = rest.rfind('@'); at != std::string_view::npos) {
    const std::string_view user = rest.substr(0, at);
    if (user.find(':') != std::string_view::npos) {
      // refused without echoing the URL: it holds the password
      return Error{kBadUrl,
                   fmt::format("--mqtt: the URL holds a password, which every user of this "
                               "machine can read in the process list (ps); give the user alone "
                               "in the URL and the password in a file (?password-file=FILE, "
                               "readable by you only) or in the environment variable {}",
                               kPasswordEnv)};
    }
    a.username = std::string(user);
    if (a.username.empty()) return bad("an empty user name before '@'");
    rest = rest.substr(at + 1);
  }
  const size_t colon = rest.rfind(':');
  if (colon != std::string_view::npos) {
    const std::string_view port = rest.substr(colon + 1);
    unsigned v = 0;
    const auto [end, ec] = std::from_chars(port.data(), port.data() + port.size(), v);
    if (port.empty() || ec != std::errc{} || end != port.data() + port.size() || v == 0 ||
        v > 65535) {
      return bad(fmt::format("port '{}' is not 1..65535", port));
    }
    a.port = static_cast<std::uint16_t>(v);
    rest = rest.substr(0, colon);
  }
  if (rest.empty()) return bad("no host");
  if (rest.find_first_of("/#") != std::string_view::npos) return bad("a path after the host");
  a.host = std::string(rest);
  while (!query.empty()) {
    const size_t amp = query.find('&');
    const std::string_view item = query.substr(0, amp);
    query = amp == std::string_view::npos ? std::string_view{} : query.substr(amp + 1);
    if (item.empty()) continue;
    const size_t eq = item.find('=');
    const std::string_view key = item.substr(0, eq);
    const std::string value(eq == std::string_view::npos ? std::string_view{}
                                                         : item.substr(eq + 1));
    if (value.empty()) return bad(fmt::format("'{}' without a file", key));
    if (key == "password-file") {
      a.password_file = value;
      continue;
    }
    std::string* file = key == "ca"     ? &a.ca_file
                        : key == "cert" ? &a.cert_file
                        : key == "key"  ? &a.key_file
                                        : nullptr;
    if (file == nullptr) {
      return bad(fmt::format("unknown option '{}' (known: ca, cert, key, password-file)", key));
    }
    if (!a.tls) return bad(fmt::format("'{}' is a TLS option: use mqtts://", key));
    *file = value;
  }
  if (a.cert_file.empty() != a.key_file.empty()) {
    return bad("a client certificate needs both cert= and key=");
  }
  return a;
}

std::string broker_label(const BrokerAddress& a) {
  return fmt::format("{}://{}{}{}:{}", a.tls ? "mqtts" : "mqtt", a.username,
                     a.username.empty() ? "" : "@", a.host, a.port);
}

Result<Command> parse_command(std::string_view payload, std::string_view robot,
                              std::string* id_json) {
  if (id_json != nullptr) *id_json = "null";
  if (payload.size() > kMaxCommandBytes) {
    return Error{kOversized, fmt::format("command payload of {} bytes: at most {} accepted",
                                         payload.size(), kMaxCommandBytes)};
  }
  const nlohmann::json j = nlohmann::json::parse(payload, nullptr, false);
  if (j.is_discarded() || !j.is_object()) {
    return Error{kMalformed,
                 "command payload is not a JSON object: expected {\"id\": ..., \"statement\": "
                 "\"...\"}"};
  }
  Command c;
  const auto id = j.find("id");
  if (id != j.end() && (id->is_string() || id->is_number())) {
    c.id_json = id->dump();
    if (id_json != nullptr) *id_json = c.id_json;
  } else {
    return Error{kMalformed, "command payload: \"id\" must be a string or a number"};
  }
  if (const auto r = j.find("robot"); r != j.end()) {
    if (!r->is_string() || r->get<std::string>() != robot) {
      return Error{kWrongRobot, fmt::format("command for robot {} on the topic of robot '{}'",
                                            r->dump(), robot)};
    }
  }
  const auto st = j.find("statement");
  if (st == j.end() || !st->is_string()) {
    return Error{kMalformed, "command payload: \"statement\" must be a string"};
  }
  c.statement = st->get<std::string>();
  if (c.statement.find_first_of("\r\n") != std::string::npos) {
    return Error{kMalformed, "command payload: one statement per command (no line breaks)"};
  }
  return c;
}

namespace {
std::string with_id(std::string_view id_json, nlohmann::json body) {
  nlohmann::json j = nlohmann::json::object();
  // the id as it was sent (already valid JSON: it came out of the parser)
  j["id"] = nlohmann::json::parse(id_json, nullptr, false);
  if (j["id"].is_discarded()) j["id"] = nullptr;
  j.update(body);
  return j.dump();
}
}  // namespace

std::string reply_ok(std::string_view id_json, std::string_view result) {
  return with_id(id_json, {{"ok", true}, {"result", std::string(result)}});
}

std::string reply_error(std::string_view id_json, const Error& error) {
  return with_id(id_json, {{"ok", false}, {"code", error.code}, {"error", error.message}});
}

}  // namespace scaratwin::fleet
