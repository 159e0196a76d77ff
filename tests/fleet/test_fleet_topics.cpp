// The fleet's topic layout and payloads (fleet/topics.hpp): names, broker addresses and the
// command checks that stand between a broker and the robot.
#include <fmt/format.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "scaratwin/fleet/fleet_watch.hpp"
#include "scaratwin/fleet/topics.hpp"

namespace scaratwin::fleet {
namespace {

using nlohmann::json;

TEST(FleetTopics, OneVersionedSubtreePerRobot) {
  const RobotTopics t = robot_topics("cell-3.left");
  EXPECT_EQ(t.connection, "scaratwin/v1/cell-3.left/connection");
  EXPECT_EQ(t.state, "scaratwin/v1/cell-3.left/state");
  EXPECT_EQ(t.command, "scaratwin/v1/cell-3.left/command");
  EXPECT_EQ(t.reply, "scaratwin/v1/cell-3.left/reply");
}

TEST(FleetTopics, RobotNamesAreOneTopicLevelWithoutWildcards) {
  EXPECT_TRUE(check_robot_name("scara_2"));
  for (const char* bad : {"", "a/b", "a+", "#", "a b"}) {
    const Status s = check_robot_name(bad);
    ASSERT_FALSE(s) << bad;
    EXPECT_EQ(s.error().code, kBadRobotName);
  }
  EXPECT_EQ(check_robot_name("a/b").error().message,
            "robot name 'a/b': '/' is not allowed in a topic level (use letters, digits, '-', "
            "'_' and '.')");
  EXPECT_FALSE(check_robot_name(std::string(65, 'a')));
}

TEST(FleetTopics, BrokerUrls) {
  auto a = parse_broker_url("mqtt://localhost");
  ASSERT_TRUE(a);
  EXPECT_EQ(a->host, "localhost");
  EXPECT_EQ(a->port, 1883);
  auto b = parse_broker_url("mqtt://10.0.0.2:18830/");
  ASSERT_TRUE(b);
  EXPECT_EQ(b->host, "10.0.0.2");
  EXPECT_EQ(b->port, 18830);
  EXPECT_FALSE(b->tls);
  constexpr const char* kExpected =
      "(expected mqtt://[USER@]HOST[:PORT] or "
      "mqtts://[USER@]HOST[:PORT][?ca=FILE&cert=FILE&key=FILE])";
  EXPECT_EQ(parse_broker_url("tcp://x:1").error().message,
            fmt::format("--mqtt 'tcp://x:1': not an mqtt:// or mqtts:// address {}", kExpected));
  EXPECT_EQ(parse_broker_url("mqtt://x:0").error().message,
            fmt::format("--mqtt 'mqtt://x:0': port '0' is not 1..65535 {}", kExpected));
  auto c = parse_broker_url("mqtt://hub@rabbit.lab:1884?password-file=/run/pw");
  ASSERT_TRUE(c);
  EXPECT_EQ(c->username, "hub");
  EXPECT_EQ(c->password, "");
  EXPECT_EQ(c->password_file, "/run/pw");
  EXPECT_EQ(c->host, "rabbit.lab");
  EXPECT_EQ(c->port, 1884);
  EXPECT_EQ(broker_label(*c), "mqtt://hub@rabbit.lab:1884");
  EXPECT_FALSE(parse_broker_url("mqtt://@x"));
  EXPECT_FALSE(parse_broker_url("mqtt://:1883"));
  EXPECT_FALSE(parse_broker_url("mqtt://x:99999"));
  EXPECT_FALSE(parse_broker_url("mqtt://x/path"));
}

// docs/security.md: a password never travels in a process's arguments, so the URL refuses
// one, and says where to put it; the refusal does not repeat it
TEST(FleetTopics, APasswordInTheUrlIsRefusedWithTheWayToGiveIt) {
  for (const char* url :
       {"mqtt://hub:s3cret@rabbit.lab:1884", "mqtts://hub:s3cret@lab", "mqtts://hub:@lab"}) {
    auto r = parse_broker_url(url);
    ASSERT_FALSE(r) << url;
    EXPECT_EQ(r.error().code, kBadUrl);
    EXPECT_EQ(r.error().message,
              "--mqtt: the URL holds a password, which every user of this machine can read in "
              "the process list (ps); give the user alone in the URL and the password in a file "
              "(?password-file=FILE, readable by you only) or in the environment variable "
              "SCARATWIN_MQTT_PASSWORD");
    EXPECT_EQ(r.error().message.find("s3cret"), std::string::npos);
  }
}

TEST(FleetTopics, TlsUrls) {
  auto a = parse_broker_url("mqtts://broker.lab");
  ASSERT_TRUE(a);
  EXPECT_TRUE(a->tls);
  EXPECT_EQ(a->port, 8883);  // MQTT over TLS's registered port
  EXPECT_EQ(a->ca_file, "");
  EXPECT_EQ(broker_label(*a), "mqtts://broker.lab:8883");
  auto b = parse_broker_url(
      "mqtts://cell-3@broker.lab:18883/?ca=/etc/lab/ca.crt&cert=/etc/lab/c.crt&key=/etc/lab/"
      "c.key&password-file=/run/pw");
  ASSERT_TRUE(b) << b.error().message;
  EXPECT_EQ(b->host, "broker.lab");
  EXPECT_EQ(b->port, 18883);
  EXPECT_EQ(b->username, "cell-3");
  EXPECT_EQ(b->ca_file, "/etc/lab/ca.crt");
  EXPECT_EQ(b->cert_file, "/etc/lab/c.crt");
  EXPECT_EQ(b->key_file, "/etc/lab/c.key");
  EXPECT_EQ(b->password_file, "/run/pw");
  const auto refused = [](const char* url) {
    auto r = parse_broker_url(url);
    return r ? std::string("accepted") : r.error().message;
  };
  EXPECT_EQ(refused("mqtt://x?ca=/ca.crt").substr(0, 58),
            "--mqtt 'mqtt://x?ca=/ca.crt': 'ca' is a TLS option: use mq");
  EXPECT_NE(refused("mqtts://x?cert=/c.crt")
                .find("a client certificate needs both cert= and "
                      "key="),
            std::string::npos);
  EXPECT_NE(refused("mqtts://x?key=/c.key").find("needs both"), std::string::npos);
  EXPECT_NE(refused("mqtts://x?cafile=/ca.crt")
                .find("unknown option 'cafile' (known: ca, cert, key, password-file)"),
            std::string::npos);
  EXPECT_NE(refused("mqtts://x?ca=").find("'ca' without a file"), std::string::npos);
}

TEST(FleetTopics, CommandsAreCheckedBeforeAnythingRuns) {
  std::string id;
  auto c = parse_command(R"({"id": "a1", "statement": "move 0.2 0 0.03"})", "r1", &id);
  ASSERT_TRUE(c);
  EXPECT_EQ(c->id_json, "\"a1\"");
  EXPECT_EQ(c->statement, "move 0.2 0 0.03");
  EXPECT_TRUE(parse_command(R"({"id": 7, "statement": "home", "robot": "r1"})", "r1", &id));
  EXPECT_EQ(id, "7");

  const auto refused = [&](std::string_view payload) {
    auto r = parse_command(payload, "r1", &id);
    EXPECT_FALSE(r) << payload;
    return r ? Error{} : r.error();
  };
  EXPECT_EQ(refused("[1]").code, kMalformed);
  EXPECT_EQ(id, "null");
  EXPECT_EQ(refused("{\"statement\": \"home\"").code, kMalformed);
  EXPECT_EQ(refused(R"({"statement": "home"})").message,
            "command payload: \"id\" must be a string or a number");
  EXPECT_EQ(refused(R"({"id": "q", "statement": 3})").message,
            "command payload: \"statement\" must be a string");
  EXPECT_EQ(id, "\"q\"") << "the id read so far goes into the error reply";
  EXPECT_EQ(refused(R"({"id": 1, "statement": "home\nmove 1 1 1"})").code, kMalformed);
  const Error wrong = refused(R"({"id": 1, "statement": "home", "robot": "r2"})");
  EXPECT_EQ(wrong.code, kWrongRobot);
  EXPECT_EQ(wrong.message, "command for robot \"r2\" on the topic of robot 'r1'");
  const std::string big = R"({"id": 1, "statement": ")" + std::string(4100, 'x') + "\"}";
  EXPECT_EQ(refused(big).message,
            "command payload of " + std::to_string(big.size()) + " bytes: at most 4096 accepted");
}

TEST(FleetTopics, RepliesEchoTheId) {
  EXPECT_EQ(json::parse(reply_ok("\"a1\"", "homed")),
            json({{"id", "a1"}, {"ok", true}, {"result", "homed"}}));
  EXPECT_EQ(json::parse(reply_error("7", Error{kBusy, "busy"})),
            json({{"id", 7}, {"ok", false}, {"code", kBusy}, {"error", "busy"}}));
  EXPECT_EQ(json::parse(reply_error("null", Error{kMalformed, "x"}))["id"], nullptr);
}

}  // namespace
}  // namespace scaratwin::fleet

// A broker address where nobody listens (port 1): the watcher only retries in the background.
static scaratwin::fleet::BrokerAddress nowhere() {
  scaratwin::fleet::BrokerAddress a;
  a.host = "127.0.0.1";
  a.port = 1;
  return a;
}

// The fleet page's watcher: which messages it keeps, without a broker (it is pointed at a
// port where none listens, so it only retries in the background).
TEST(FleetWatch, KeepsEachRobotsLastStateAndConnectionAndNothingElse) {
  using scaratwin::fleet::FleetWatcher;
  auto w = FleetWatcher::start(nowhere(), {});
  ASSERT_TRUE(w) << w.error().message;
  FleetWatcher& f = **w;
  f.on_message("scaratwin/v1/r2/connection", "online");
  f.on_message("scaratwin/v1/r2/state", R"({"robot": "r2", "seq": 7, "mode": "idle"})");
  f.on_message("scaratwin/v1/r2/state", R"({"robot": "r2", "seq": 8, "mode": "moving"})");
  f.on_message("scaratwin/v1/r1/connection", "offline");
  f.on_message("scaratwin/v1/r1/connection", "gone fishing");  // not a connection word
  // ignored: another leaf, another prefix, no leaf, a name that is not one topic level
  f.on_message("scaratwin/v1/r2/reply", R"({"id": 1, "ok": true})");
  f.on_message("scaratwin/v2/r3/state", R"({"seq": 1})");
  f.on_message("scaratwin/v1/r4", "online");
  f.on_message("scaratwin/v1/r#5/state", R"({"seq": 1})");
  // malformed: not JSON, not an object, larger than the cap
  f.on_message("scaratwin/v1/r2/state", "{\"seq\": 9");
  f.on_message("scaratwin/v1/r2/state", "[9]");
  f.on_message("scaratwin/v1/r2/state", "{\"pad\": \"" + std::string(16384, 'x') + "\"}");

  const auto c = f.counters();
  EXPECT_EQ(c.states, 2u);
  EXPECT_EQ(c.malformed, 3u);
  EXPECT_EQ(c.ignored, 4u);
  const auto snap = nlohmann::json::parse(f.snapshot_json());
  EXPECT_EQ(snap["broker"], "mqtt://127.0.0.1:1");
  EXPECT_EQ(snap["connected"], false);
  ASSERT_EQ(snap["robots"].size(), 2u);
  EXPECT_EQ(snap["robots"][0]["name"], "r1");  // sorted by name
  EXPECT_EQ(snap["robots"][0]["connection"], "?");
  EXPECT_TRUE(snap["robots"][0]["state"].is_null());
  EXPECT_TRUE(snap["robots"][0]["age_ms"].is_null());
  EXPECT_EQ(snap["robots"][1]["name"], "r2");
  EXPECT_EQ(snap["robots"][1]["connection"], "online");
  EXPECT_EQ(snap["robots"][1]["state"]["seq"], 8);  // the last well-formed state
  EXPECT_EQ(snap["robots"][1]["state"]["mode"], "moving");
  EXPECT_EQ(snap["robots"][1]["states"], 2);
  EXPECT_GE(snap["robots"][1]["age_ms"].get<double>(), 0.0);
}

// docs/fleet.md: "a state over 16 KiB is not parsed": 16,384 bytes are, 16,385 are not
TEST(FleetWatch, AStateOf16KiBIsKeptOneByteMoreIsNot) {
  using scaratwin::fleet::FleetWatcher;
  auto w = FleetWatcher::start(nowhere(), {});
  ASSERT_TRUE(w) << w.error().message;
  const std::string head = "{\"pad\": \"", tail = "\"}";
  const std::string at_cap = head + std::string(16384 - head.size() - tail.size(), 'x') + tail;
  ASSERT_EQ(at_cap.size(), 16384u);
  (*w)->on_message("scaratwin/v1/r1/state", at_cap);
  EXPECT_EQ((*w)->counters().states, 1u);
  EXPECT_EQ((*w)->counters().malformed, 0u);
  (*w)->on_message("scaratwin/v1/r1/state", head + "y" + at_cap.substr(head.size()));
  EXPECT_EQ((*w)->counters().states, 1u);
  EXPECT_EQ((*w)->counters().malformed, 1u);
}

TEST(FleetWatch, AStrangerCannotGrowItBeyondItsRobotCap) {
  using scaratwin::fleet::FleetWatcher;
  auto w = FleetWatcher::start(nowhere(), {});
  ASSERT_TRUE(w) << w.error().message;
  // docs/fleet.md: "at most 1,000 robots are kept" (the number from the docs, not the code)
  for (std::size_t i = 0; i < 1000 + 5; ++i) {
    (*w)->on_message("scaratwin/v1/r" + std::to_string(i) + "/connection", "online");
  }
  EXPECT_EQ((*w)->robots().size(), 1000u);
  EXPECT_EQ((*w)->counters().ignored, 5u);
  EXPECT_FALSE(FleetWatcher::start(scaratwin::fleet::BrokerAddress{}, {}));  // no host
}
