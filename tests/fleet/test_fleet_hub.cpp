// The fleet end to end (docs/fleet.md): a real Mosquitto on a free loopback port, the real
// `scaratwin hub` holding the emulated robot (the firmware in simavr, --plant ideal) and the
// simulator, and an MQTT client in the test. Judged by what the broker carries and by the
// emulator's truth channel (the motor positions from the firmware's STEP/DIR pins).
#include <arpa/inet.h>
#include <netinet/in.h>
#include <signal.h>
#include <sys/socket.h>
#include <unistd.h>

#include <array>
#include <chrono>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <sstream>
#include <thread>

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "mqtt_peer.hpp"
#include "scaratwin/hub/process.hpp"
#include "scaratwin/hub/twin_db.hpp"
#include "tls_lab.hpp"

namespace scaratwin {
namespace {

namespace fs = std::filesystem;
using namespace std::chrono_literals;
using nlohmann::json;
using test::Message;
using test::Peer;

const fs::path kBin = SCARATWIN_BIN_DIR;
const fs::path kBroker = SCARATWIN_MOSQUITTO;
const fs::path kConfig = SCARATWIN_CONFIG_DIR;
constexpr double kZStepsPerM = 205560.0;

fs::path fresh_dir(const char* name) {
  fs::path p = fs::temp_directory_path() / fmt::format("scaratwin-{}-{}", name, getpid());
  fs::remove_all(p);
  fs::create_directories(p);
  return p;
}

// The emulator's side channel: "query" answers a TR line of the true motor positions.
class Truth {
 public:
  explicit Truth(int port) : port_(port) {}
  std::int64_t get(const std::string& key) {
    const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
    sockaddr_in addr{};
    addr.sin_family = AF_INET;
    addr.sin_port = htons(static_cast<std::uint16_t>(port_));
    addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    if (::connect(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0) {
      ::close(fd);
      return INT64_MIN;
    }
    timeval tv{2, 0};
    ::setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof tv);
    const std::string q = "rate 0\nquery\n";
    (void)::send(fd, q.data(), q.size(), MSG_NOSIGNAL);
    std::string in;
    char buf[1024];
    while (in.find("TR ") == std::string::npos ||
           in.find('\n', in.find("TR ")) == std::string::npos) {
      const ssize_t n = ::recv(fd, buf, sizeof buf, 0);
      if (n <= 0) break;
      in.append(buf, static_cast<std::size_t>(n));
    }
    ::close(fd);
    const size_t tr = in.find("TR ");
    if (tr == std::string::npos) return INT64_MIN;
    std::istringstream line(in.substr(tr, in.find('\n', tr) - tr));
    std::string tok;
    while (line >> tok) {
      if (tok.rfind(key + "=", 0) == 0) return std::stoll(tok.substr(key.size() + 1));
    }
    return INT64_MIN;
  }
  std::array<std::int64_t, 3> motors() { return {get("z"), get("j2"), get("j3")}; }

 private:
  int port_;
};

struct Rig {
  fs::path dir, pty;
  std::unique_ptr<ChildProcess> robot, sim, broker, hub;
  std::string sim_port;
  int side_port = 0;
  int broker_port = 0;

  void start(const fs::path& d) {
    dir = d;
    pty = dir / "robot.pty";
    auto r =
        ChildProcess::start(kBin / "scaratwin-robot",
                            {"--pty-link", pty.string(), "--plant", "ideal"}, dir / "robot.log");
    ASSERT_TRUE(r) << r.error().message;
    robot = std::move(*r);
    auto s =
        ChildProcess::start(kBin / "scaratwin-sim",
                            {"--port", "0", "--http-port", "0", "--no-camera"}, dir / "sim.log");
    ASSERT_TRUE(s) << s.error().message;
    sim = std::move(*s);
    auto side = robot->wait_for_line("side channel: ", 60s);
    ASSERT_TRUE(side) << side.error().message;
    side_port = std::stoi(side->substr(side->rfind(':') + 1));
    auto listening = sim->wait_for_line("listening on", 60s);
    ASSERT_TRUE(listening) << listening.error().message;
    const size_t paren = listening->find(" (");
    const size_t colon = listening->rfind(':', paren);
    sim_port = listening->substr(colon + 1, paren - colon - 1);
    broker_port = test::free_loopback_port();
  }
  std::vector<std::string> links() const {
    return {"--serial", pty.string(),
            "--sim",    "127.0.0.1:" + sim_port,
            "--db",     (dir / "twin.db").string()};
  }
  void start_hub(const std::string& name, std::string url = "") {
    if (url.empty()) url = fmt::format("mqtt://127.0.0.1:{}", broker_port);
    std::vector<std::string> args{"hub", "--mqtt", url, "--name", name, "--state-hz", "20"};
    for (const std::string& a : links()) args.push_back(a);
    auto h = ChildProcess::start(kBin / "scaratwin", args, dir / "hub.log");
    ASSERT_TRUE(h) << h.error().message;
    hub = std::move(*h);
    auto ready = hub->wait_for_line("scaratwin hub: robot '" + name + "' ready", 60s);
    ASSERT_TRUE(ready) << ready.error().message;
  }
};

json parse(const Message& m) { return json::parse(m.payload, nullptr, false); }

// Sends a command and waits for its reply.
json command(Peer& peer, const std::string& robot, const std::string& id,
             const std::string& statement, std::chrono::seconds timeout = 120s) {
  const std::size_t mark = peer.count();
  EXPECT_TRUE(peer.publish(fmt::format("scaratwin/v1/{}/command", robot),
                           json{{"id", id}, {"statement", statement}}.dump()));
  auto r = peer.wait(
      fmt::format("scaratwin/v1/{}/reply", robot),
      [&](const Message& m) { return parse(m).value("id", json()) == id; }, timeout, mark);
  return r ? parse(*r) : json();
}

// The whole life of a hub on a broker, in one run (each start of the emulated robot costs
// seconds): the broker down at start, then up; state; a command that moves the robot; a
// refused one; malformed payloads; another robot's topic; the last will when killed.
TEST(FleetHub, ServesItsRobotOnTheBrokerAndOnlyIts) {
  Rig rig;
  ASSERT_NO_FATAL_FAILURE(rig.start(fresh_dir("fleet")));
  Truth truth(rig.side_port);

  // the CLI's own answer to a target out of reach: the oracle for the refusal over MQTT
  std::string cli_error;
  {
    std::vector<std::string> args{"move", "0.5", "0", "0.05"};
    for (const std::string& a : rig.links()) args.push_back(a);
    auto cli = ChildProcess::start(kBin / "scaratwin", args, rig.dir / "cli.log");
    ASSERT_TRUE(cli);
    ASSERT_EQ((*cli)->wait_exit(60s), 1) << (*cli)->output_tail();
    auto line = (*cli)->wait_for_line("scaratwin move: ", 1s);
    ASSERT_TRUE(line) << (*cli)->output_tail();
    cli_error = line->substr(std::string("scaratwin move: ").size());
  }

  // and to a statement that does not parse (refused before any link is opened)
  std::string cli_parse_error;
  {
    auto cli = ChildProcess::start(kBin / "scaratwin", {"move", "0.2", "0"}, rig.dir / "cli2.log");
    ASSERT_TRUE(cli);
    ASSERT_EQ((*cli)->wait_exit(60s), 2) << (*cli)->output_tail();
    auto line = (*cli)->wait_for_line("scaratwin move: ", 1s);
    ASSERT_TRUE(line) << (*cli)->output_tail();
    cli_parse_error = line->substr(std::string("scaratwin move: ").size());
  }

  // the broker is down when the hub starts: the twin runs on, and the bridge says so
  ASSERT_NO_FATAL_FAILURE(rig.start_hub("r1"));
  auto down =
      rig.hub->wait_for_line(fmt::format("broker mqtt://127.0.0.1:{}: ", rig.broker_port), 20s);
  ASSERT_TRUE(down) << rig.hub->output_tail();
  EXPECT_NE(down->find("retrying"), std::string::npos) << *down;

  // it comes up: the hub connects by itself, announces itself (retained) and publishes state
  auto broker = test::start_broker(kBroker, rig.dir, rig.broker_port);
  ASSERT_TRUE(broker) << broker.error().message;
  rig.broker = std::move(*broker);
  Peer peer(rig.broker_port, "scaratwin/v1/#");
  ASSERT_TRUE(peer.ok());
  auto online = peer.wait(
      "scaratwin/v1/r1/connection", [](const Message& m) { return m.payload == "online"; }, 30s);
  ASSERT_TRUE(online) << rig.hub->output_tail();
  auto state = peer.wait(
      "scaratwin/v1/r1/state",
      [](const Message& m) { return parse(m).value("link", json())["robot"] == true; }, 10s);
  ASSERT_TRUE(state) << rig.hub->output_tail();
  const json s0 = parse(*state);
  EXPECT_EQ(s0["robot"], "r1");
  EXPECT_EQ(s0["mode"], "not-homed");
  EXPECT_TRUE(s0["joints"]["d1_m"].is_number()) << s0.dump();
  EXPECT_EQ(s0["link"]["sim"], true);
  EXPECT_EQ(s0["job"]["running"], false);

  // a command moves the robot: judged by the truth, not by the hub's word
  const json home = command(peer, "r1", "h1", "home");
  ASSERT_EQ(home.value("ok", false), true) << home.dump() << rig.hub->output_tail();
  EXPECT_EQ(home["result"], "homed");
  auto homed = peer.wait(
      "scaratwin/v1/r1/state",
      [](const Message& m) {
        const json j = parse(m);
        return j["mode"] == "idle" && std::abs(j["joints"]["d1_m"].get<double>() - 0.12) < 1e-3;
      },
      10s);
  EXPECT_TRUE(homed) << "the state shows the robot homed at d1 = 0.12 m";
  const json move = command(peer, "r1", "m1", "movej 0.10 0 0 0");
  ASSERT_EQ(move.value("ok", false), true) << move.dump();
  EXPECT_NE(move["result"].get<std::string>().find("points"), std::string::npos) << move.dump();
  EXPECT_NEAR(static_cast<double>(truth.get("z")), 0.10 * kZStepsPerM, 200.0);
  auto moved = peer.wait(
      "scaratwin/v1/r1/state",
      [](const Message& m) {
        const json j = parse(m);
        return j["mode"] == "idle" && j["job"]["done"] == 2 &&
               std::abs(j["joints"]["d1_m"].get<double>() - 0.10) < 1e-3;
      },
      10s);
  EXPECT_TRUE(moved) << "the state shows the move and the job count";

  // stop does not wait its turn: it interrupts the move in progress, which fails, and stops
  // the robot on its way (judged by the truth)
  const std::size_t before_long = peer.count();
  ASSERT_TRUE(peer.publish("scaratwin/v1/r1/command",
                           json{{"id", "long"}, {"statement", "movej 0.02 0 0 0"}}.dump()));
  const auto z_at = [&](double d1_m) { return static_cast<std::int64_t>(d1_m * kZStepsPerM); };
  for (int i = 0; i < 600 && truth.get("z") > z_at(0.10) - 2000; ++i) {
    std::this_thread::sleep_for(50ms);
  }
  ASSERT_LT(truth.get("z"), z_at(0.10) - 2000) << "the long move started";
  const json stop = command(peer, "r1", "s", "stop");
  EXPECT_EQ(stop.value("ok", false), true) << stop.dump();
  auto long_reply = peer.wait(
      "scaratwin/v1/r1/reply", [](const Message& m) { return parse(m)["id"] == "long"; }, 10s,
      before_long);
  ASSERT_TRUE(long_reply);
  EXPECT_EQ(parse(*long_reply)["ok"], false);
  EXPECT_NE(parse(*long_reply).value("error", "").find("interrupted"), std::string::npos)
      << long_reply->payload;
  // at rest: no step over 300 ms of the emulated robot's own clock, which advanced (a stalled
  // emulator keeps still too)
  const auto z_stop = truth.get("z");
  const auto sim_from = truth.get("sim_us");
  for (int i = 0; i < 500 && truth.get("sim_us") < sim_from + 300000; ++i) {
    std::this_thread::sleep_for(20ms);
  }
  ASSERT_GE(truth.get("sim_us"), sim_from + 300000) << "the emulated robot's clock advanced";
  EXPECT_EQ(truth.get("z"), z_stop) << "the robot is at rest";
  EXPECT_GT(z_stop, z_at(0.02) + 2000) << "stopped on its way, not at the end of the move";

  // refused at the CLI -> refused over MQTT with the same message; nothing moves
  const auto before = truth.motors();
  const json refused = command(peer, "r1", "bad", "move 0.5 0 0.05");
  EXPECT_EQ(refused.value("ok", true), false) << refused.dump();
  EXPECT_EQ(refused.value("error", ""), cli_error);
  const json parse_error = command(peer, "r1", "bad2", "move 0.2 0");
  EXPECT_EQ(parse_error.value("ok", true), false);
  EXPECT_EQ(parse_error.value("error", ""), cli_parse_error);

  // docs/fleet.md's refusals, each with its documented words: `shoot FILE`; the ninth command
  // waiting behind a running one (the queue holds 8); a retained command further down
  {
    const json shot = command(peer, "r1", "shot", "shoot a.png");
    EXPECT_EQ(shot.value("ok", true), false);
    EXPECT_EQ(shot.value("error", ""),
              "shoot a.png: over MQTT a picture is not saved on the hub's machine: send 'shoot' "
              "alone");
    const std::size_t m0 = peer.count();
    ASSERT_TRUE(peer.publish("scaratwin/v1/r1/command",
                             json{{"id", "q0"}, {"statement", "wait 3"}}.dump()));
    // running (not waiting) once the state's job shows it
    ASSERT_TRUE(peer.wait(
        "scaratwin/v1/r1/state",
        [](const Message& m) { return parse(m)["job"]["running"] == true; }, 10s, m0));
    for (int i = 1; i <= 9; ++i) {
      ASSERT_TRUE(
          peer.publish("scaratwin/v1/r1/command",
                       json{{"id", fmt::format("q{}", i)}, {"statement", "wait 0"}}.dump()));
    }
    auto busy = peer.wait(
        "scaratwin/v1/r1/reply", [](const Message& m) { return parse(m)["id"] == "q9"; }, 10s, m0);
    ASSERT_TRUE(busy);
    EXPECT_EQ(parse(*busy)["error"],
              "robot 'r1' is busy: 8 commands already wait (--queue); nothing was done");
    for (int i = 0; i <= 8; ++i) {
      auto r = peer.wait(
          "scaratwin/v1/r1/reply",
          [&](const Message& m) { return parse(m)["id"] == fmt::format("q{}", i); }, 20s, m0);
      ASSERT_TRUE(r) << "q" << i;
      EXPECT_EQ(parse(*r)["ok"], true) << r->payload;
    }
  }

  // malformed and oversized payloads: a clear error, nothing run
  std::size_t mark = peer.count();
  ASSERT_TRUE(peer.publish("scaratwin/v1/r1/command", "{not json"));
  auto bad_json = peer.wait(
      "scaratwin/v1/r1/reply", [](const Message&) { return true; }, 10s, mark);
  ASSERT_TRUE(bad_json);
  EXPECT_EQ(parse(*bad_json)["ok"], false);
  EXPECT_TRUE(parse(*bad_json)["id"].is_null());
  EXPECT_NE(parse(*bad_json)["error"].get<std::string>().find("not a JSON object"),
            std::string::npos);
  mark = peer.count();
  const std::string oversized =
      json{{"id", 9}, {"statement", "movej 0.05 0 0 0" + std::string(5000, ' ')}}.dump();
  ASSERT_TRUE(peer.publish("scaratwin/v1/r1/command", oversized));
  auto big = peer.wait(
      "scaratwin/v1/r1/reply", [](const Message&) { return true; }, 10s, mark);
  ASSERT_TRUE(big);
  EXPECT_EQ(parse(*big)["error"],
            fmt::format("command payload of {} bytes: at most 4096 accepted", oversized.size()));

  // another robot's command topic: r1 never acts on it. Then a command to r1: its reply comes
  // after anything r1 would have said to the other one
  mark = peer.count();
  ASSERT_TRUE(peer.publish("scaratwin/v1/r2/command",
                           json{{"id", "x"}, {"statement", "movej 0.05 0 0 0"}}.dump()));
  const json after = command(peer, "r1", "w1", "wait 0");
  EXPECT_EQ(after.value("ok", false), true) << after.dump();
  for (const Message& m : peer.since(mark)) {
    EXPECT_NE(m.topic, "scaratwin/v1/r2/reply") << m.payload;
    if (m.topic == "scaratwin/v1/r1/reply") {
      EXPECT_NE(parse(m)["id"], "x") << m.payload;
    }
  }
  EXPECT_EQ(truth.motors(), before) << "nothing moved on a refused or foreign command";

  // killed (no goodbye): the broker publishes the last will, retained
  mark = peer.count();
  ASSERT_EQ(::kill(rig.hub->pid(), SIGKILL), 0);
  (void)rig.hub->wait_exit(10s);
  auto offline = peer.wait(
      "scaratwin/v1/r1/connection", [](const Message& m) { return m.payload == "offline"; }, 20s,
      mark);
  ASSERT_TRUE(offline) << "the last will reads offline";
  Peer late(rig.broker_port, "scaratwin/v1/r1/connection");
  auto retained = late.wait(
      "scaratwin/v1/r1/connection", [](const Message& m) { return m.retain; }, 10s);
  ASSERT_TRUE(retained);
  EXPECT_EQ(retained->payload, "offline") << "a dashboard that comes later reads offline too";

  // a retained command, published while no hub listens: the broker hands it to the next hub
  // as it subscribes (a live subscriber gets it unretained), which refuses it, runs nothing,
  // and says why; then it is cleared from the broker
  const auto before_retained = truth.motors();
  mark = peer.count();
  ASSERT_TRUE(peer.publish("scaratwin/v1/r1/command",
                           json{{"id", "ret"}, {"statement", "movej 0.05 0 0 0"}}.dump(), true));
  ASSERT_NO_FATAL_FAILURE(rig.start_hub("r1"));
  auto ret = peer.wait(
      "scaratwin/v1/r1/reply", [](const Message& m) { return parse(m)["id"] == "ret"; }, 30s, mark);
  ASSERT_TRUE(ret) << rig.hub->output_tail();
  EXPECT_EQ(parse(*ret)["ok"], false);
  EXPECT_EQ(parse(*ret)["error"], "retained command refused: publish commands without retain");
  ASSERT_TRUE(peer.publish("scaratwin/v1/r1/command", "", true));
  EXPECT_EQ(truth.motors(), before_retained) << "nothing moved on the retained command";

  // SIGTERM ends a hub as Ctrl-C does (status 130), and it reads offline (its own goodbye; a
  // broker cannot tell it from the will, which the closed socket would also fire)
  ASSERT_TRUE(late.wait(
      "scaratwin/v1/r1/connection", [](const Message& m) { return m.payload == "online"; }, 30s));
  mark = late.count();
  ASSERT_EQ(::kill(rig.hub->pid(), SIGTERM), 0);
  EXPECT_EQ(rig.hub->wait_exit(20s), 130) << rig.hub->output_tail();
  EXPECT_TRUE(late.wait(
      "scaratwin/v1/r1/connection", [](const Message& m) { return m.payload == "offline"; }, 10s,
      mark));
}

// What a process shows to every user of the machine (ps): its arguments.
std::string command_line(pid_t pid) {
  std::ifstream in(fmt::format("/proc/{}/cmdline", pid));
  std::string s((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  for (char& c : s) c = c == '\0' ? ' ' : c;
  return s;
}

// The fleet over TLS with the password out of every command line (docs/fleet.md, "A broker
// over TLS"): a hub with the wrong CA moves nothing, whatever is published on its robot's
// topic; one with the right CA and the password in a file is driven; and a simulator's fleet
// page watches the same broker over TLS. Judged by the emulator's truth and /proc.
TEST(FleetHub, OverTlsTheRightCaDrivesTheRobotAWrongOneMovesNothing) {
  Rig rig;
  ASSERT_NO_FATAL_FAILURE(rig.start(fresh_dir("fleet-tls")));
  Truth truth(rig.side_port);
  auto made = test::start_tls_lab(rig.dir / "tls", kBroker, SCARATWIN_MOSQUITTO_PASSWD);
  ASSERT_TRUE(made) << made.error().message;
  test::TlsLab& lab = *made;
  test::PeerAuth auth;
  auth.host = "localhost";
  auth.ca = lab.ca.string();
  auth.user = lab.user;
  auth.password = lab.password;
  Peer peer(lab.port_ok, "scaratwin/v1/#", auth);
  ASSERT_TRUE(peer.ok());
  const std::string base = fmt::format("mqtts://{}@localhost:{}", lab.user, lab.port_ok);

  // the wrong CA, the password from the environment: refused, said, and nothing moves
  ::setenv("SCARATWIN_MQTT_PASSWORD", lab.password.c_str(), 1);
  ASSERT_NO_FATAL_FAILURE(rig.start_hub("tls", base + "?ca=" + lab.other_ca.string()));
  ::unsetenv("SCARATWIN_MQTT_PASSWORD");
  auto said = rig.hub->wait_for_line("TLS: the broker's certificate is refused", 20s);
  ASSERT_TRUE(said) << rig.hub->output_tail();
  EXPECT_EQ(command_line(rig.hub->pid()).find(lab.password), std::string::npos);
  const auto at_start = truth.motors();
  ASSERT_TRUE(
      peer.publish("scaratwin/v1/tls/command", json{{"id", "h0"}, {"statement", "home"}}.dump()));
  std::this_thread::sleep_for(3s);
  EXPECT_EQ(truth.motors(), at_start) << "a hub refused by TLS runs nothing";
  EXPECT_FALSE(peer.wait(
      "scaratwin/v1/tls/reply", [](const Message&) { return true; }, 100ms));
  EXPECT_EQ(rig.hub->stop(10s), 130);

  // the right CA, the password in a file named by the URL
  const std::string good =
      fmt::format("{}?ca={}&password-file={}", base, lab.ca.string(), lab.password_file.string());
  ASSERT_NO_FATAL_FAILURE(rig.start_hub("tls", good));
  auto connected = rig.hub->wait_for_line("connected over TLS", 20s);
  ASSERT_TRUE(connected) << rig.hub->output_tail();
  ASSERT_TRUE(peer.wait(
      "scaratwin/v1/tls/connection", [](const Message& m) { return m.payload == "online"; }, 20s));
  const std::string shown = command_line(rig.hub->pid());
  EXPECT_NE(shown.find(lab.password_file.string()), std::string::npos) << shown;
  EXPECT_EQ(shown.find(lab.password), std::string::npos) << shown;
  const json home = command(peer, "tls", "h1", "home");
  ASSERT_EQ(home.value("ok", false), true) << home.dump() << rig.hub->output_tail();
  const json move = command(peer, "tls", "m1", "movej 0.10 0 0 0");
  ASSERT_EQ(move.value("ok", false), true) << move.dump();
  EXPECT_NEAR(static_cast<double>(truth.get("z")), 0.10 * kZStepsPerM, 200.0);

  // the fleet page's watcher over TLS: connected, and its arguments hold no password either
  auto sim =
      ChildProcess::start(kBin / "scaratwin-sim",
                          {"--port", "0", "--http-port", std::to_string(test::free_loopback_port()),
                           "--no-camera", "--mqtt", good},
                          rig.dir / "sim2.log");
  ASSERT_TRUE(sim) << sim.error().message;
  auto watching = (*sim)->wait_for_line(
      fmt::format("fleet: broker mqtts://{}@localhost:{} connected", lab.user, lab.port_ok), 60s);
  EXPECT_TRUE(watching) << (*sim)->output_tail();
  EXPECT_EQ(command_line((*sim)->pid()).find(lab.password), std::string::npos);
}

// One hub drives every robot of a workcell (docs/workcell.md, "The hub's robot interface"):
// `scaratwin hub --workcell config/two_arms.toml` with a serial port per robot opens both
// robots' interfaces, mirrors both into the one simulator, records each into its own database
// and serves each on its own topics, at the same time. Judged by each emulator's truth channel.
TEST(FleetHub, OneHubDrivesEveryRobotOfAWorkcell) {
  const fs::path dir = fresh_dir("fleet-cell");
  const fs::path cell = kConfig / "two_arms.toml";
  std::unique_ptr<ChildProcess> robots[2];
  fs::path ptys[2];
  int side[2] = {0, 0};
  const char* names[2] = {"left", "right"};
  for (int i = 0; i < 2; ++i) {
    ptys[i] = dir / fmt::format("{}.pty", names[i]);
    auto r = ChildProcess::start(kBin / "scaratwin-robot",
                                 {"--pty-link", ptys[i].string(), "--plant", "ideal"},
                                 dir / fmt::format("{}.log", names[i]));
    ASSERT_TRUE(r) << r.error().message;
    robots[i] = std::move(*r);
  }
  auto sim = ChildProcess::start(
      kBin / "scaratwin-sim",
      {"--workcell", cell.string(), "--port", "0", "--http-port", "0", "--no-camera"},
      dir / "sim.log");
  ASSERT_TRUE(sim) << sim.error().message;
  for (int i = 0; i < 2; ++i) {
    auto line = robots[i]->wait_for_line("side channel: ", 60s);
    ASSERT_TRUE(line) << line.error().message;
    side[i] = std::stoi(line->substr(line->rfind(':') + 1));
  }
  auto listening = (*sim)->wait_for_line("listening on", 60s);
  ASSERT_TRUE(listening) << listening.error().message;
  const size_t paren = listening->find(" (");
  const size_t colon = listening->rfind(':', paren);
  const std::string sim_port = listening->substr(colon + 1, paren - colon - 1);
  const int broker_port = test::free_loopback_port();
  auto broker = test::start_broker(kBroker, dir, broker_port);
  ASSERT_TRUE(broker) << broker.error().message;
  Peer peer(broker_port, "scaratwin/v1/#");
  ASSERT_TRUE(peer.ok());

  auto hub = ChildProcess::start(
      kBin / "scaratwin",
      {"hub", "--workcell", cell.string(), "--serial", "left=" + ptys[0].string(), "--serial",
       "right=" + ptys[1].string(), "--sim", "127.0.0.1:" + sim_port, "--db",
       (dir / "twin.db").string(), "--mqtt", fmt::format("mqtt://127.0.0.1:{}", broker_port),
       "--state-hz", "20"},
      dir / "hub.log");
  ASSERT_TRUE(hub) << hub.error().message;
  for (const char* name : names) {
    auto ready = (*hub)->wait_for_line(fmt::format("scaratwin hub: robot '{}' ready", name), 60s);
    ASSERT_TRUE(ready) << (*hub)->output_tail();
  }
  // "ready" comes before the broker's answer: a command published then would reach no
  // subscriber and be lost. Each bridge subscribes to its command topic before it publishes
  // "online", and the broker keeps one client's packets in order, so "online" means subscribed.
  for (const char* name : names) {
    ASSERT_TRUE(peer.wait(
        fmt::format("scaratwin/v1/{}/connection", name),
        [](const Message& m) { return m.payload == "online"; }, 30s))
        << name << (*hub)->output_tail();
  }
  Truth truth[2] = {Truth(side[0]), Truth(side[1])};

  // both home at once: two commands out, two replies back, each on its robot's topic
  const auto both = [&](const std::string& id, const std::string& left, const std::string& right) {
    const std::size_t mark = peer.count();
    EXPECT_TRUE(
        peer.publish("scaratwin/v1/left/command", json{{"id", id}, {"statement", left}}.dump()));
    EXPECT_TRUE(
        peer.publish("scaratwin/v1/right/command", json{{"id", id}, {"statement", right}}.dump()));
    std::array<json, 2> replies;
    for (int i = 0; i < 2; ++i) {
      auto r = peer.wait(
          fmt::format("scaratwin/v1/{}/reply", names[i]),
          [&](const Message& m) { return parse(m).value("id", json()) == id; }, 120s, mark);
      if (r) replies[static_cast<std::size_t>(i)] = parse(*r);
    }
    return replies;
  };
  const auto homed = both("h", "home", "home");
  for (int i = 0; i < 2; ++i) {
    ASSERT_EQ(homed[static_cast<std::size_t>(i)].value("ok", false), true)
        << names[i] << ": " << homed[static_cast<std::size_t>(i)].dump() << (*hub)->output_tail();
  }
  const auto z_at = [](double d1_m) { return static_cast<std::int64_t>(d1_m * kZStepsPerM); };
  for (int i = 0; i < 2; ++i) {
    EXPECT_NEAR(static_cast<double>(truth[i].get("z")), static_cast<double>(z_at(0.12)), 200.0)
        << names[i] << " homed at d1 = 120 mm";
  }

  // each its own move, at the same time: left down to 40 mm, right to 50 mm. Watched on both
  // truth channels: there is a moment when both carriages are on their way.
  const std::size_t mark = peer.count();
  ASSERT_TRUE(peer.publish("scaratwin/v1/left/command",
                           json{{"id", "m"}, {"statement", "movej 0.04 0 0 0"}}.dump()));
  ASSERT_TRUE(peer.publish("scaratwin/v1/right/command",
                           json{{"id", "m"}, {"statement", "movej 0.05 0 0 0"}}.dump()));
  bool together = false;
  for (int k = 0; k < 1000 && !together; ++k) {
    const std::int64_t zl = truth[0].get("z");
    const std::int64_t zr = truth[1].get("z");
    together = zl < z_at(0.12) - 500 && zl > z_at(0.04) + 500 && zr < z_at(0.12) - 500 &&
               zr > z_at(0.05) + 500;
    if (!together) std::this_thread::sleep_for(10ms);
  }
  EXPECT_TRUE(together) << "the two robots moved one after the other, not at once";
  for (int i = 0; i < 2; ++i) {
    auto r = peer.wait(
        fmt::format("scaratwin/v1/{}/reply", names[i]),
        [&](const Message& m) { return parse(m).value("id", json()) == "m"; }, 120s, mark);
    ASSERT_TRUE(r) << names[i] << (*hub)->output_tail();
    EXPECT_EQ(parse(*r).value("ok", false), true) << r->payload;
  }
  EXPECT_NEAR(static_cast<double>(truth[0].get("z")), static_cast<double>(z_at(0.04)), 200.0);
  EXPECT_NEAR(static_cast<double>(truth[1].get("z")), static_cast<double>(z_at(0.05)), 200.0);

  // a command one robot refuses moves neither; the other still answers
  const auto before = std::array{truth[0].motors(), truth[1].motors()};
  const auto refused = both("r", "wait 0", "move 0.5 0 0.05");
  EXPECT_EQ(refused[0].value("ok", false), true) << refused[0].dump();
  EXPECT_EQ(refused[1].value("ok", true), false) << refused[1].dump();
  EXPECT_NE(refused[1].value("error", "").find("reach"), std::string::npos) << refused[1].dump();
  EXPECT_EQ(truth[0].motors(), before[0]);
  EXPECT_EQ(truth[1].motors(), before[1]);

  // each robot's state on its own topic, mirrored from its own robot
  for (int i = 0; i < 2; ++i) {
    const double d1 = i == 0 ? 0.04 : 0.05;
    auto state = peer.wait(
        fmt::format("scaratwin/v1/{}/state", names[i]),
        [&](const Message& m) {
          const json j = parse(m);
          return j["robot"] == names[i] && j["link"]["sim"] == true &&
                 std::abs(j["joints"]["d1_m"].get<double>() - d1) < 1e-3;
        },
        10s);
    EXPECT_TRUE(state) << names[i] << "'s state shows its own carriage at " << d1 << " m";
  }

  // SIGTERM stops both (status 130) and both read offline
  const std::size_t before_end = peer.count();
  ASSERT_EQ(::kill((*hub)->pid(), SIGTERM), 0);
  EXPECT_EQ((*hub)->wait_exit(30s), 130) << (*hub)->output_tail();
  for (const char* name : names) {
    EXPECT_TRUE(peer.wait(
        fmt::format("scaratwin/v1/{}/connection", name),
        [](const Message& m) { return m.payload == "offline"; }, 10s, before_end))
        << name;
  }

  // one database each, beside --db: the hub's run, and the robot's own reports in it
  EXPECT_FALSE(fs::exists(dir / "twin.db"));
  for (int i = 0; i < 2; ++i) {
    auto db = TwinDb::open(dir / fmt::format("twin-{}.db", names[i]));
    ASSERT_TRUE(db) << db.error().message;
    auto runs = (*db)->runs();
    ASSERT_TRUE(runs);
    ASSERT_EQ(runs->size(), 1u) << names[i];
    EXPECT_EQ(runs->front().kind, "hub");
    auto samples = (*db)->samples(runs->front().id, SampleSource::kPhysical);
    ASSERT_TRUE(samples);
    ASSERT_FALSE(samples->empty()) << names[i];
    EXPECT_NEAR(samples->back().q[0], i == 0 ? 0.04 : 0.05, 1e-3) << names[i];
  }
}

}  // namespace
}  // namespace scaratwin
