// The control statements at the command line (`scaratwin move X Y Z`, `grip`, `spawn red X Y`,
// `mirror --seconds N`, ...) and `scaratwin run FILE`, against a running simulator and robot.
#include <pthread.h>
#include <signal.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <optional>
#include <sstream>
#include <thread>

#include <fmt/format.h>

#include "commands.hpp"
#include "hub_session.hpp"
#include "scaratwin/config/robot_config.hpp"
#include "scaratwin/config/workcell_config.hpp"
#include "scaratwin/hub/hub.hpp"
#include "scaratwin/hub/process.hpp"
#include "scaratwin/hub/runner.hpp"
#include "scaratwin/kinematics/workcell.hpp"
#include "scaratwin/protocol/codec_core.h"
#include "scaratwin/session/port_owner.hpp"
#include "scaratwin/session/say.hpp"

namespace scaratwin::cli {
namespace {

struct StatementArgs {
  std::string name;
  std::vector<std::string> words;
  std::string file;
  double seconds = 5.0;
};

void print_result(const Statement& st, const std::string& result) {
  fmt::print("{}\n", session::statement_line(st, result));
  std::fflush(stdout);
}

// When a `scaratwin hub` owns the robot's port (session/port_owner.hpp), the statement or the
// script goes to it: the robot it holds stays as it is (homed), where opening the port would
// reset a Uno. Nothing when no owner holds the port (the command opens it itself); else the
// exit status.
std::optional<int> on_the_owner(const LinkArgs& l, const std::string& kind,
                                const session::OwnerRequest& request) {
  if (!l.workcell.empty()) return std::nullopt;
  auto device = session::single_serial_device(l);
  if (!device) return std::nullopt;
  auto r = session::ask_owner(*device, request, session::say_on_stdout());
  if (!r) return std::nullopt;
  if (*r) return kExitOk;
  std::fprintf(stderr, "scaratwin %s: %s\n", kind.c_str(), r->error().message.c_str());
  return r->error().code == error_code(HubError::kInterrupted) ? kExitInterrupted : kExitFailure;
}

// A statement refused because the robot is not homed, said with what a board that resets on
// every open needs: a hub that keeps its port.
Status with_owner_hint(Status s, const LinkArgs& l) {
  if (s || s.error().code != protocol_error_code(protocol::core::kErrNotHomed) ||
      !session::single_serial_device(l)) {
    return s;
  }
  Error e = s.error();
  e.message +=
      ". If an earlier statement homed it, the board reset when this one opened its "
      "port (as a Uno does): keep the port with `scaratwin hub` in a terminal of its "
      "own, and the statements go to it (docs/owner.md)";
  return e;
}

int run_statement(const CommonOptions& common, const LinkArgs& l, const StatementArgs& a) {
  std::string text = a.name;
  for (const std::string& w : a.words) text += " " + w;
  if (a.name == "mirror") text = fmt::format("mirror {}", a.seconds);
  auto st = parse_statement(text, 0);
  if (!st) {
    std::fprintf(stderr, "scaratwin %s: %s\n", a.name.c_str(), st.error().message.c_str());
    return kExitUsage;
  }
  if (st->kind == StatementKind::kShoot && !st->text.empty()) {
    // the owner saves the picture: where this command was asked for
    std::error_code ec;
    text = "shoot " + std::filesystem::absolute(st->text, ec).string();
  }
  if (auto owned = on_the_owner(l, a.name, session::OwnerRequest{text, {}, {}})) return *owned;
  return with_hub(common, l, a.name, text,
                  [&](Hub& hub) { return with_owner_hint(execute(hub, *st, print_result), l); });
}

int run_file(const CommonOptions& common, const LinkArgs& l, const StatementArgs& a) {
  std::ifstream in(a.file);
  if (!in) {
    std::fprintf(stderr, "scaratwin run: cannot read '%s'\n", a.file.c_str());
    return kExitUsage;
  }
  std::stringstream ss;
  ss << in.rdbuf();
  // parse everything first: a script with a syntax error moves nothing.
  auto script = parse_script(ss.str(), a.file);
  if (!script) {
    std::fprintf(stderr, "scaratwin run: %s\n", script.error().message.c_str());
    return kExitUsage;
  }
  if (auto owned = on_the_owner(l, "run", session::OwnerRequest{{}, ss.str(), a.file})) {
    return *owned;
  }
  return with_hub(common, l, "script", a.file, [&](Hub& hub) {
    return with_owner_hint(run_script(hub, *script, a.file, print_result), l);
  });
}

}  // namespace

void add_statement_commands(CLI::App& app, CommonOptions& common, Runner& run) {
  auto links = std::make_shared<LinkArgs>();
  struct Spec {
    const char* name;
    const char* help;
    const char* args;
  };
  static constexpr Spec kSpecs[] = {
      {"home", "home the physical robot against its endstops", nullptr},
      {"stop", "stop the physical robot at once (halted until the next home or motion)", nullptr},
      {"move", "move the tool to X Y Z (m) [YAW (deg)]; the virtual robot follows", "X Y Z [YAW]"},
      {"line", "move the tool in a straight line to X Y Z (m) [YAW (deg)]", "X Y Z [YAW]"},
      {"movej", "move the joints to D1 (m) Q2 Q3 Q4 (deg)", "D1 Q2 Q3 Q4"},
      {"grip", "close the gripper", nullptr},
      {"release", "open the gripper", nullptr},
      {"shoot", "take a camera picture [FILE.png]", "[FILE]"},
      {"spawn", "spawn a cube in the virtual scene: red|green|blue X Y (m)", "COLOR X Y"},
      {"reset", "remove every cube from the virtual scene", nullptr},
      {"pick", "pick cube ID and place it in the tray of its colour", "ID"},
      {"sort", "camera shot, colour recognition, sort every cube into its tray", nullptr},
  };
  for (const Spec& s : kSpecs) {
    auto a = std::make_shared<StatementArgs>();
    a->name = s.name;
    CLI::App* cmd = app.add_subcommand(s.name, s.help);
    cmd->group("Statements");
    if (s.args != nullptr) {
      cmd->add_option("args", a->words, s.args)->allow_extra_args();
    }
    add_link_options(*cmd, *links);
    add_common_options(*cmd, common, false);
    cmd->callback([&common, &run, links, a] {
      run = [&common, links, a] { return run_statement(common, *links, *a); };
    });
  }
  auto m = std::make_shared<StatementArgs>();
  m->name = "mirror";
  CLI::App* mirror = app.add_subcommand(
      "mirror",
      "mirror the physical robot in the virtual one for a while; prints latency and loss");
  mirror->group("Statements");
  mirror->add_option("--seconds", m->seconds, "how long")->capture_default_str();
  add_link_options(*mirror, *links);
  // at 115200 baud the serial line carries up to 300 reports a second without loss
  // (docs/benchmarks.md, "Physical link"); the firmware takes 0..1000
  mirror
      ->add_option("--report-hz", links->report_hz,
                   "the robot's state reports per second, each one a mirrored frame")
      ->check(CLI::Range(1, 1000))
      ->capture_default_str();
  add_common_options(*mirror, common, false);
  mirror->callback([&common, &run, links, m] {
    run = [&common, links, m] { return run_statement(common, *links, *m); };
  });

  auto f = std::make_shared<StatementArgs>();
  CLI::App* file = app.add_subcommand(
      "run", "run a script of statements (one per line; see docs); stops at the first error");
  file->add_option("file", f->file, "script file")->required();
  add_link_options(*file, *links);
  add_common_options(*file, common, false);
  file->callback([&common, &run, links, f] {
    run = [&common, links, f] { return run_file(common, *links, *f); };
  });
}

}  // namespace scaratwin::cli
