// `scaratwin hub`: a long-running hub. It holds the robot and the simulator links, mirrors
// and records continuously, and with --mqtt URL joins the fleet on a message broker
// (docs/fleet.md): it publishes its robot's state and runs the statements that arrive on its
// own command topic, one at a time, with the CLI's checks, answering each on the reply topic.
#include <cstdio>
#include <future>
#include <memory>
#include <mutex>
#include <optional>

#include <fmt/format.h>

#include "commands.hpp"
#include "hub_session.hpp"
#include "scaratwin/config/workcell_config.hpp"
#include "scaratwin/fleet/topics.hpp"
#include "scaratwin/kinematics/workcell.hpp"
#include "scaratwin/session/hub_service.hpp"
#include "scaratwin/session/port_owner.hpp"

namespace scaratwin::cli {
namespace {

// --mqtt, and the service's options (--name, --state-hz, --queue; the broker from --mqtt)
struct HubArgs {
  std::string mqtt;
  session::HubServiceOptions service;
};

Status serve(Hub& hub, const session::HubServiceOptions& o, session::PortOwner* owner) {
  return session::serve_hub(hub, o, owner, session::say_on_stdout());
}

// Every robot of the workcell in one hub: each served on a thread of its own (its own queue,
// its own topics), until Ctrl-C interrupts them all or one of them fails (then the others are
// interrupted too).
Status serve_all(const std::vector<NamedHub>& hubs, const session::HubServiceOptions& a) {
  std::vector<std::future<void>> served;
  std::mutex mu;
  std::optional<Status> first;  // the first session to end says why they all ended
  for (const NamedHub& h : hubs) {
    served.push_back(std::async(std::launch::async, [&, h] {
      session::HubServiceOptions own = a;
      own.name = h.name;
      own.log_prefix = h.name + ": ";
      Status s = serve(*h.hub, own, nullptr);
      std::lock_guard<std::mutex> lock(mu);
      if (first) return;
      first =
          s ? s : Error{s.error().code, fmt::format("robot '{}': {}", h.name, s.error().message)};
      for (const NamedHub& other : hubs) {
        if (other.hub != h.hub) other.hub->interrupt();
      }
    }));
  }
  for (auto& f : served) f.get();
  return first ? *first : Status{Ok{}};
}

int run_hub(const CommonOptions& common, const LinkArgs& l, HubArgs args) {
  session::HubServiceOptions& a = args.service;
  if (!args.mqtt.empty()) {
    auto b = fleet::parse_broker_url(args.mqtt);
    if (!b) {
      std::fprintf(stderr, "scaratwin hub: %s\n", b.error().message.c_str());
      return kExitUsage;
    }
    a.broker = *b;
  }
  if (!l.workcell.empty() && l.robot.empty()) {
    // a workcell of several robots: all of them, each under its workcell name
    auto cell = load_workcell_config(l.workcell);
    if (!cell) {
      std::fprintf(stderr, "scaratwin hub: %s\n", cell.error().message.c_str());
      return kExitUsage;
    }
    if (cell->robots.size() > 1) {
      if (!a.name.empty()) {
        std::fprintf(stderr,
                     "scaratwin hub: --name: this hub drives the %zu robots of %s under their "
                     "own names (%s); --robot NAME drives one of them alone\n",
                     cell->robots.size(), l.workcell.c_str(), robot_names(*cell).c_str());
        return kExitUsage;
      }
      return with_hubs(common, l, "hub", l.workcell,
                       [&](const std::vector<NamedHub>& hubs) { return serve_all(hubs, a); });
    }
  }
  auto model = load_model(common);
  if (!model) return kExitUsage;
  if (a.name.empty()) a.name = model->name;
  if (Status s = fleet::check_robot_name(a.name); !s) {
    std::fprintf(stderr, "scaratwin hub: --name: %s\n", s.error().message.c_str());
    return kExitUsage;
  }
  // the port is claimed before the hub opens it: a second hub would reset the board under the
  // first one's robot
  std::unique_ptr<session::PortOwner> owner;
  if (auto device = session::single_serial_device(l)) {
    auto o = session::PortOwner::claim(*device);
    if (!o) {
      std::fprintf(stderr, "scaratwin hub: %s\n", o.error().message.c_str());
      return kExitFailure;
    }
    owner = std::move(*o);
  }
  return with_hub(common, l, "hub", a.name, [&](Hub& hub) { return serve(hub, a, owner.get()); });
}

}  // namespace

void add_hub_command(CLI::App& app, CommonOptions& common, Runner& run) {
  auto links = std::make_shared<LinkArgs>();
  auto a = std::make_shared<HubArgs>();
  CLI::App* cmd = app.add_subcommand(
      "hub",
      "run the hub until Ctrl-C: mirror and record continuously; with --mqtt publish the "
      "robot's state and take statements on the fleet's topics (docs/fleet.md)");
  cmd->add_option("--mqtt", a->mqtt,
                  "MQTT broker to join: mqtt://[USER@]HOST[:PORT] (port 1883) or, over TLS, "
                  "mqtts://[USER@]HOST[:PORT][?ca=FILE&cert=FILE&key=FILE] (port 8883); the "
                  "password from ?password-file=FILE or $SCARATWIN_MQTT_PASSWORD, never the URL "
                  "(docs/fleet.md)");
  cmd->add_option("--name", a->service.name,
                  "the robot's name in the topics (default: the description's robot name)");
  cmd->add_option("--state-hz", a->service.state_hz, "state messages per second")
      ->check(CLI::Range(0.1, 100.0))
      ->capture_default_str();
  cmd->add_option("--queue", a->service.queue, "commands that may wait behind the running one")
      ->check(CLI::Range(1, 1000))
      ->capture_default_str();
  add_link_options(*cmd, *links);
  add_common_options(*cmd, common, false);
  cmd->callback([&common, &run, links, a] {
    run = [&common, links, a] { return run_hub(common, *links, *a); };
  });
}

}  // namespace scaratwin::cli
