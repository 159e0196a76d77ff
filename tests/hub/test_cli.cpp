// The command line's promises (README.md), through the real `scaratwin` executable: bad input
// exits 2 with a message naming the value; an unreachable target exits 1 and says why; the
// robot description comes from --config or SCARATWIN_CONFIG; a script with a syntax error
// moves nothing, judged by the emulator's truth on a robot that starts away from home.
#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include "hub_test_support.hpp"
#include "scaratwin/config/robot_config.hpp"
#include "scaratwin/hub/process.hpp"

namespace scaratwin {
namespace {

namespace fs = std::filesystem;
using namespace std::chrono_literals;

const fs::path kBin = SCARATWIN_BIN_DIR;

fs::path fresh_dir(const char* name) { return test::fresh_dir(std::string("cli-") + name); }

using test::Outcome;

Outcome run_cli(const std::vector<std::string>& args) {
  return test::run_program(kBin / "scaratwin", args);
}

std::string joined(const std::vector<std::string>& args) {
  std::string s = "scaratwin";
  for (const auto& a : args) s += " " + a;
  return s;
}

// The first number after `key` in the output (fk --json prints "x_m": 0.254).
double number_after(const std::string& text, const std::string& key) {
  const auto at = text.find(key);
  if (at == std::string::npos) return NAN;
  const auto num = text.find_first_of("-0123456789", at + key.size());
  if (num == std::string::npos) return NAN;
  return std::strtod(text.c_str() + num, nullptr);
}

TEST(Cli, BadInputExitsTwoNamingTheValue) {
  const std::vector<std::pair<std::vector<std::string>, std::string>> cases = {
      {{"fk", "0.12", "abc", "0", "0"}, "abc"},
      {{"fk", "0.12", "0", "0"}, "received 3"},
      {{"ik", "0.2", "0.05", "-0.02", "1e999"}, "YAW_DEG = inf"},
      {{"plan", "--to", "0.1", "30", "45", "10", "--samples", "-3"}, "-3"},
      {{"plan", "--to", "0.1", "30", "45", "10", "--speed-scale", "1.5"}, "1.5"},
      {{"plan", "--line", "0.2", "0.05", "nan", "0"}, "Z_M = nan"},
      {{"fly"}, "fly"},
      // the firmware takes 0..1000 reports a second; a mirror needs at least one
      {{"mirror", "--report-hz", "1001", "--serial", "/dev/null"}, "1001"},
      {{"mirror", "--report-hz", "0", "--serial", "/dev/null"}, "--report-hz"},
      {{"fk", "--config", "/nonexistent/robot.toml", "0.12", "0", "0", "0"},
       "/nonexistent/robot.toml"},
      // an address is HOST:PORT with nothing after the port's digits
      {{"mirror", "--serial", "/dev/null", "--sim", "127.0.0.1:55016x"}, "127.0.0.1:55016x"},
      {{"mirror", "--serial", "/dev/null", "--sim", ":55016"}, "':55016'"},
      {{"mirror", "--serial", "/dev/null", "--sim", "127.0.0.1:65536"}, "65536"},
      {{"calibrate", "--serial", "/dev/null", "--camera", "127.0.0.1:cam"}, "127.0.0.1:cam"},
  };
  for (const auto& [args, named] : cases) {
    const Outcome o = run_cli(args);
    EXPECT_EQ(o.status, 2) << joined(args) << "\n" << o.output;
    EXPECT_NE(o.output.find(named), std::string::npos)
        << joined(args) << ": the message does not name '" << named << "'\n"
        << o.output;
  }
}

TEST(Cli, AnUnreachableTargetExitsOneSayingWhy) {
  const std::vector<std::pair<std::vector<std::string>, std::string>> cases = {
      {{"ik", "0.5", "0", "-0.02", "0"}, "beyond the reach"},
      {{"ik", "0.068", "0", "-0.02", "0"}, "dead zone"},
      {{"ik", "0.2", "0", "0.1", "0"}, "Z"},
      {{"ik", "-0.03", "-0.1", "-0.02", "0"}, "limits"},
  };
  for (const auto& [args, why] : cases) {
    const Outcome o = run_cli(args);
    EXPECT_EQ(o.status, 1) << joined(args) << "\n" << o.output;
    EXPECT_NE(o.output.find(why), std::string::npos)
        << joined(args) << ": expected the reason '" << why << "'\n"
        << o.output;
  }
}

// A description whose upper arm is 8 mm longer than the paper's: at the home pose the tool is
// at x = a1 + a2 + a3 = 0.067 + 0.100 + 0.095 m, computed here by hand, not by the library.
TEST(Cli, TheRobotDescriptionComesFromConfigOrTheEnvironment) {
  const fs::path dir = fresh_dir("config");
  std::string text;
  {
    std::ifstream in(SCARATWIN_CONFIG_FILE);
    std::stringstream ss;
    ss << in.rdbuf();
    text = ss.str();
  }
  const std::string paper_a2 = "a_m = 0.092";
  ASSERT_NE(text.find(paper_a2), std::string::npos);
  text.replace(text.find(paper_a2), paper_a2.size(), "a_m = 0.100");
  const fs::path longer = dir / "longer.toml";
  std::ofstream(longer) << text;
  const double paper_x_mm = (0.067 + 0.092 + 0.095) * 1000.0;
  const double longer_x_mm = (0.067 + 0.100 + 0.095) * 1000.0;

  const std::vector<std::string> fk = {"fk", "0.12", "0", "0", "0", "--json"};
  ::unsetenv("SCARATWIN_CONFIG");
  Outcome o = run_cli(fk);
  ASSERT_EQ(o.status, 0) << o.output;
  EXPECT_NEAR(number_after(o.output, "\"x_m\"") * 1000.0, paper_x_mm, 1e-6) << o.output;

  std::vector<std::string> with_config = fk;
  with_config.insert(with_config.end(), {"--config", longer.string()});
  o = run_cli(with_config);
  ASSERT_EQ(o.status, 0) << o.output;
  EXPECT_NEAR(number_after(o.output, "\"x_m\"") * 1000.0, longer_x_mm, 1e-6) << o.output;

  ::setenv("SCARATWIN_CONFIG", longer.c_str(), 1);
  o = run_cli(fk);
  EXPECT_EQ(o.status, 0) << o.output;
  EXPECT_NEAR(number_after(o.output, "\"x_m\"") * 1000.0, longer_x_mm, 1e-6) << o.output;
  // --config wins over the environment
  std::vector<std::string> paper = fk;
  paper.insert(paper.end(), {"--config", SCARATWIN_CONFIG_FILE});
  o = run_cli(paper);
  EXPECT_EQ(o.status, 0) << o.output;
  EXPECT_NEAR(number_after(o.output, "\"x_m\"") * 1000.0, paper_x_mm, 1e-6) << o.output;
  // a description the environment names but that does not exist is bad configuration
  ::setenv("SCARATWIN_CONFIG", (dir / "missing.toml").c_str(), 1);
  o = run_cli(fk);
  EXPECT_EQ(o.status, 2) << o.output;
  EXPECT_NE(o.output.find((dir / "missing.toml").string()), std::string::npos) << o.output;
  ::unsetenv("SCARATWIN_CONFIG");
  // a key the loader does not know is named
  std::ofstream(dir / "typo.toml") << text << "\n[limits]\nj5_deg = [0.0, 1.0]\n";
  std::vector<std::string> typo = fk;
  typo.insert(typo.end(), {"--config", (dir / "typo.toml").string()});
  o = run_cli(typo);
  EXPECT_EQ(o.status, 2) << o.output;
  fs::remove_all(dir);
}

// `scaratwin model --workcell FILE` writes the whole workcell, each robot's names prefixed;
// a workcell it cannot keep apart exits 2 naming the file and the robots; without the flag the
// model is the robot's alone.
TEST(Cli, ModelWritesAWorkcell) {
  const fs::path dir = fresh_dir("workcell");
  const fs::path config = fs::path(SCARATWIN_CONFIG_FILE).parent_path();
  const auto read = [](const fs::path& p) {
    std::ifstream in(p);
    std::stringstream ss;
    ss << in.rdbuf();
    return ss.str();
  };
  Outcome o = run_cli({"model", "--workcell", (config / "two_arms.toml").string(), "--mjcf",
                       (dir / "cell.xml").string(), "--urdf", (dir / "cell.urdf").string()});
  ASSERT_EQ(o.status, 0) << o.output;
  const std::string mjcf = read(dir / "cell.xml");
  for (const char* want : {"<mujoco model=\"workcell\">", "<body name=\"left/base_frame\"",
                           "<body name=\"right/base_frame\"", "<joint name=\"right/j1\"",
                           "<site name=\"left/tool\"", "<camera name=\"overhead\""}) {
    EXPECT_NE(mjcf.find(want), std::string::npos) << want;
  }
  EXPECT_NE(read(dir / "cell.urdf").find("<joint name=\"right/base_fixed\" type=\"fixed\">"),
            std::string::npos);

  // two bases 111.8 mm apart
  std::string text = read(config / "two_arms.toml");
  for (const auto& [from, to] :
       {std::pair<std::string, std::string>{"x_mm = 400.0", "x_mm = 100.0"},
        {"y_mm = 200.0", "y_mm = 50.0"}}) {
    ASSERT_NE(text.find(from), std::string::npos) << from;
    text.replace(text.find(from), from.size(), to);
  }
  const std::string scara = "description = \"scara.toml\"";
  for (auto at = text.find(scara); at != std::string::npos; at = text.find(scara)) {
    text.replace(at, scara.size(), "description = \"" + (config / "scara.toml").string() + "\"");
  }
  std::ofstream(dir / "close.toml") << text;
  o = run_cli({"model", "--workcell", (dir / "close.toml").string(), "--mjcf",
               (dir / "close.xml").string()});
  EXPECT_EQ(o.status, 2) << o.output;
  EXPECT_NE(o.output.find((dir / "close.toml").string()), std::string::npos) << o.output;
  EXPECT_NE(o.output.find("robots 'left' and 'right'"), std::string::npos) << o.output;
  EXPECT_NE(o.output.find("111.8 mm apart"), std::string::npos) << o.output;
  EXPECT_FALSE(fs::exists(dir / "close.xml"));

  // --config and --workcell together
  o = run_cli({"model", "--workcell", (config / "two_arms.toml").string(), "--config",
               SCARATWIN_CONFIG_FILE, "--mjcf", (dir / "both.xml").string()});
  EXPECT_EQ(o.status, 2) << o.output;
  EXPECT_NE(o.output.find("--config and --workcell"), std::string::npos) << o.output;

  // without the flag: the robot alone, unprefixed
  o = run_cli({"model", "--config", SCARATWIN_CONFIG_FILE, "--mjcf", (dir / "one.xml").string()});
  ASSERT_EQ(o.status, 0) << o.output;
  const std::string one = read(dir / "one.xml");
  EXPECT_NE(one.find("<joint name=\"j1\""), std::string::npos);
  EXPECT_EQ(one.find("/j1"), std::string::npos);
  fs::remove_all(dir);
}

// One truth sample of the emulator's side channel, as key=value pairs.
using test::truth;

// A script is parsed whole before anything moves: a syntax error on its last line leaves the
// robot where it was. The robot starts away from home (so "still at home" would prove
// nothing) and the emulator counts every STEP pulse: there must be none.
TEST(Cli, AScriptWithASyntaxErrorOnItsLastLineMovesNothing) {
  const fs::path dir = fresh_dir("script");
  auto robot = ChildProcess::start(kBin / "scaratwin-robot",
                                   {"--plant", "ideal", "--pty-link", (dir / "robot.pty").string(),
                                    "--start-steps", "20000,-300,500"},
                                   dir / "robot.log");
  ASSERT_TRUE(robot) << robot.error().message;
  auto sim = ChildProcess::start(
      kBin / "scaratwin-sim", {"--port", "0", "--http-port", "0", "--no-camera"}, dir / "sim.log");
  ASSERT_TRUE(sim) << sim.error().message;
  auto side = (*robot)->wait_for_line("side channel: ", 60s);
  ASSERT_TRUE(side) << side.error().message;
  const int side_port = std::stoi(side->substr(side->rfind(':') + 1));
  auto port = test::simulator_port(**sim);
  ASSERT_TRUE(port) << port.error().message;
  const std::string sim_port = std::to_string(*port);
  {
    std::ofstream s(dir / "bad.txt");
    s << "# every line but the last is a valid statement\n"
         "home\n"
         "move 0.18 0.05 -0.02\n"
         "grip\n"
         "movej 0.05 -20 30\n";  // four joints needed
  }
  const Outcome o =
      run_cli({"run", (dir / "bad.txt").string(), "--serial", (dir / "robot.pty").string(), "--sim",
               "127.0.0.1:" + sim_port, "--no-db"});
  EXPECT_EQ(o.status, 2) << o.output;
  EXPECT_NE(o.output.find("bad.txt:5"), std::string::npos) << "names the line\n" << o.output;
  const auto t = truth(side_port);
  ASSERT_FALSE(t.empty()) << "no truth from the emulator";
  EXPECT_EQ(t.at("steps_z"), "0");
  EXPECT_EQ(t.at("steps_j2"), "0");
  EXPECT_EQ(t.at("steps_j3"), "0");
  EXPECT_EQ(t.at("z"), "20000");
  EXPECT_EQ(t.at("j2"), "-300");
  EXPECT_EQ(t.at("j3"), "500");
  // the gripper still open: its pulse as at power-up, to within the servo interrupt's latency
  // (a cycle or two of the AVR's other interrupts: 1 cdeg is 0.1 us of pulse; closed is 7500)
  EXPECT_LE(std::abs(std::stoi(t.at("grip_cdeg"))), 2) << "the gripper still open";
  fs::remove_all(dir);
}

// The paper's description with its upper arm 8 mm longer (a2 = 0.100 m), as a file in `dir`.
fs::path longer_description(const fs::path& dir) {
  std::ifstream in(SCARATWIN_CONFIG_FILE);
  std::stringstream ss;
  ss << in.rdbuf();
  std::string text = ss.str();
  const std::string paper_a2 = "a_m = 0.092";
  const auto at = text.find(paper_a2);
  if (at == std::string::npos) ADD_FAILURE() << "no '" << paper_a2 << "' in the description";
  if (at != std::string::npos) text.replace(at, paper_a2.size(), "a_m = 0.100");
  const fs::path longer = dir / "longer.toml";
  std::ofstream(longer) << text;
  return longer;
}

std::string hash_of(const fs::path& description) {
  auto m = load_robot_config(description);
  if (!m) {
    ADD_FAILURE() << m.error().message;
    return {};
  }
  return description_hash(*m);
}

// The emulated robot (its firmware built for config/scara.toml) and a simulator started on
// `sim_config`.
struct EmulatedRig {
  std::unique_ptr<ChildProcess> robot, sim;
  fs::path pty;
  std::string sim_address;
  int side_port = 0;
};

void start_rig(const fs::path& dir, const fs::path& sim_config, EmulatedRig* rig) {
  rig->pty = dir / "robot.pty";
  auto robot =
      ChildProcess::start(kBin / "scaratwin-robot",
                          {"--plant", "ideal", "--pty-link", rig->pty.string()}, dir / "robot.log");
  ASSERT_TRUE(robot) << robot.error().message;
  rig->robot = std::move(*robot);
  auto sim = ChildProcess::start(
      kBin / "scaratwin-sim",
      {"--port", "0", "--http-port", "0", "--no-camera", "--config", sim_config.string()},
      dir / "sim.log");
  ASSERT_TRUE(sim) << sim.error().message;
  rig->sim = std::move(*sim);
  auto side = rig->robot->wait_for_line("side channel: ", 60s);
  ASSERT_TRUE(side) << side.error().message;
  rig->side_port = std::stoi(side->substr(side->rfind(':') + 1));
  auto port = test::simulator_port(*rig->sim);
  ASSERT_TRUE(port) << port.error().message;
  rig->sim_address = fmt::format("127.0.0.1:{}", *port);
}

// The hello carries the robot description's hash (docs/protocol.md section 11): a hub refuses
// a simulator started on another description, and a robot whose firmware was built for
// another, with a message naming both hashes and both parties, before anything moves; on one
// description the three connect.
TEST(Cli, AHubRefusesPeersBuiltForAnotherDescription) {
  const fs::path dir = fresh_dir("description");
  const fs::path longer = longer_description(dir);
  const std::string paper_hash = hash_of(SCARATWIN_CONFIG_FILE);
  const std::string longer_hash = hash_of(longer);
  ASSERT_EQ(paper_hash.size(), 8u);
  ASSERT_NE(paper_hash, longer_hash);
  ::unsetenv("SCARATWIN_CONFIG");
  {
    EmulatedRig rig;
    ASSERT_NO_FATAL_FAILURE(start_rig(dir, longer, &rig));
    const Outcome o = run_cli({"grip", "--serial", rig.pty.string(), "--sim", rig.sim_address,
                               "--no-db", "--config", SCARATWIN_CONFIG_FILE});
    EXPECT_EQ(o.status, 1) << o.output;
    const std::string want = fmt::format(
        "scaratwin grip: the simulator at {} was built for robot description {}, this hub for {} "
        "({}): start both with the same --config\n",
        rig.sim_address, longer_hash, paper_hash, SCARATWIN_CONFIG_FILE);
    EXPECT_NE(o.output.find(want), std::string::npos) << "expected: " << want << o.output;
    // the hub on the longer description: the robot's firmware (built for config/scara.toml)
    // is refused first
    const Outcome r = run_cli({"grip", "--serial", rig.pty.string(), "--sim", rig.sim_address,
                               "--no-db", "--config", longer.string()});
    EXPECT_EQ(r.status, 1) << r.output;
    const std::string firmware = fmt::format(
        "scaratwin grip: the physical robot's firmware on {} was built for robot description {}, "
        "this hub for {} ({}): ",
        rig.pty.string(), paper_hash, longer_hash, longer.string());
    EXPECT_NE(r.output.find(firmware), std::string::npos) << "expected: " << firmware << r.output;
    // nothing moved: no STEP pulse, the gripper still open
    const auto t = truth(rig.side_port);
    ASSERT_FALSE(t.empty()) << "no truth from the emulator";
    EXPECT_EQ(t.at("steps_z"), "0");
    EXPECT_EQ(t.at("steps_j2"), "0");
    EXPECT_EQ(t.at("steps_j3"), "0");
    EXPECT_LE(std::abs(std::stoi(t.at("grip_cdeg"))), 2) << "the gripper still open";
  }
  {
    EmulatedRig rig;
    ASSERT_NO_FATAL_FAILURE(start_rig(dir, SCARATWIN_CONFIG_FILE, &rig));
    const Outcome o = run_cli({"grip", "--serial", rig.pty.string(), "--sim", rig.sim_address,
                               "--no-db", "--config", SCARATWIN_CONFIG_FILE});
    EXPECT_EQ(o.status, 0) << o.output;
    EXPECT_EQ(o.output.find("robot description"), std::string::npos) << o.output;
  }
  fs::remove_all(dir);
}

}  // namespace
}  // namespace scaratwin
