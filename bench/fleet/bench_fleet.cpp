// Broker load test of the fleet (docs/benchmarks.md): N simulated robots, each its own MQTT
// client, publish a hub-sized JSON state on scaratwin/v1/<robot>/state at a fixed rate through
// a real Mosquitto on loopback; one dashboard client subscribed to scaratwin/v1/+/state
// measures the end-to-end latency (publish call -> delivery, one steady clock) and counts the
// messages lost (per-robot sequence numbers). Prints one row per fleet size: the cost as the
// fleet grows.
//
//   bench_fleet [--robots 25,50,100,200] [--hz 50] [--seconds 10] [--threads 2]
//               [--broker mqtt://HOST:PORT]   (default: start mosquitto on a free port)
//               [--pin 0|1]   (1: the broker it starts on CPU 0, the robots and the dashboard
//                              on CPU 1)
#include <mosquitto.h>
#include <sched.h>
#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "mqtt_peer.hpp"  // tests/fleet: the broker on a free port
#include "scaratwin/fleet/topics.hpp"
#include "scaratwin/hub/process.hpp"

namespace {

using namespace std::chrono;
using nlohmann::json;
namespace fs = std::filesystem;
namespace fleet = scaratwin::fleet;

std::int64_t now_ns() {
  return duration_cast<nanoseconds>(steady_clock::now().time_since_epoch()).count();
}

// A state payload shaped like the hub's (fleet/hub_state.cpp), about 600 bytes.
std::string state_payload(const std::string& robot, std::uint64_t seq, std::int64_t t_ns) {
  json j;
  j["robot"] = robot;
  j["seq"] = seq;
  j["t_ns"] = t_ns;
  j["mode"] = "trajectory";
  j["flags"] = 7;
  j["joints"] = {{"d1_m", 0.0812}, {"q2_deg", 31.25}, {"q3_deg", -12.5}, {"q4_deg", 90.0}};
  j["tool"] = {{"x_m", 0.2301}, {"y_m", 0.0622}, {"z_m", 0.0142}, {"yaw_deg", 108.75}};
  j["steps"] = {16692, 515, -203};
  j["grip_deg"] = 0.0;
  j["link"] = {{"robot", true}, {"robot_report_age_ms", 4.2}, {"robot_errors", 0}, {"sim", true}};
  j["mirror"] = {{"frames", 120345}, {"lost", 0}, {"latency_ms", 1.31}, {"mean_latency_ms", 1.27}};
  j["alarms"] = {{"desync", 0}, {"halted", false}, {"interrupted", false}};
  j["job"] = {{"id", "a17"},     {"statement", "move 0.2 0.05 0.02"},
              {"running", true}, {"elapsed_s", 1.25},
              {"queued", 0},     {"done", 16},
              {"failed", 1}};
  return j.dump();
}

double cpu_s_of(pid_t pid) {
  std::ifstream f(fmt::format("/proc/{}/stat", pid));
  std::string s((std::istreambuf_iterator<char>(f)), {});
  const size_t close = s.rfind(')');
  std::istringstream in(s.substr(close + 2));
  std::string tok;
  unsigned long long ut = 0, st = 0;
  for (int field = 3; in >> tok; ++field) {
    if (field == 14) ut = std::stoull(tok);
    if (field == 15) {
      st = std::stoull(tok);
      break;
    }
  }
  return static_cast<double>(ut + st) / static_cast<double>(sysconf(_SC_CLK_TCK));
}

double self_cpu_s() {
  rusage ru{};
  getrusage(RUSAGE_SELF, &ru);
  return static_cast<double>(ru.ru_utime.tv_sec + ru.ru_stime.tv_sec) +
         static_cast<double>(ru.ru_utime.tv_usec + ru.ru_stime.tv_usec) * 1e-6;
}

struct Dashboard {
  std::mutex mu;
  std::vector<std::int64_t> latency_ns;
  std::vector<std::uint64_t> received;  // per robot
  std::uint64_t reordered = 0;
  std::vector<std::int64_t> last_seq;
};

struct Row {
  int robots;
  double offered_hz, delivered_hz, p50_ms, p99_ms, max_ms;
  std::uint64_t sent, lost;
  double broker_cpu, bench_cpu;
};

Row run(const fleet::BrokerAddress& broker, pid_t broker_pid, int robots, double hz, double seconds,
        int threads) {
  Dashboard dash;
  dash.received.assign(static_cast<std::size_t>(robots), 0);
  dash.last_seq.assign(static_cast<std::size_t>(robots), -1);
  dash.latency_ns.reserve(static_cast<std::size_t>(robots * hz * seconds * 1.1));

  mosquitto* sub = mosquitto_new(nullptr, true, &dash);
  mosquitto_int_option(sub, MOSQ_OPT_TCP_NODELAY, 1);  // as the bridge does (mqtt_bridge.cpp)
  mosquitto_message_callback_set(sub, [](mosquitto*, void* u, const mosquitto_message* m) {
    const std::int64_t t = now_ns();
    auto* d = static_cast<Dashboard*>(u);
    const json j =
        json::parse(static_cast<const char*>(m->payload),
                    static_cast<const char*>(m->payload) + m->payloadlen, nullptr, false);
    if (j.is_discarded()) return;
    const std::string robot = j["robot"].get<std::string>();
    const auto i = static_cast<std::size_t>(std::stoi(robot.substr(robot.rfind('-') + 1)));
    const auto seq = j["seq"].get<std::int64_t>();
    std::lock_guard<std::mutex> lock(d->mu);
    d->latency_ns.push_back(t - j["t_ns"].get<std::int64_t>());
    ++d->received[i];
    if (seq <= d->last_seq[i]) ++d->reordered;
    d->last_seq[i] = seq;
  });
  if (mosquitto_connect(sub, broker.host.c_str(), broker.port, 30) != MOSQ_ERR_SUCCESS) {
    std::fprintf(stderr, "bench_fleet: cannot connect to the broker\n");
    std::exit(1);
  }
  mosquitto_loop_start(sub);
  mosquitto_subscribe(sub, nullptr, "scaratwin/v1/+/state", 0);
  std::this_thread::sleep_for(300ms);

  // the robots: `threads` workers, each driving its share of clients in turn
  std::vector<mosquitto*> clients;
  for (int i = 0; i < robots; ++i) {
    mosquitto* c = mosquitto_new(fmt::format("bench-robot-{}", i).c_str(), true, nullptr);
    mosquitto_int_option(c, MOSQ_OPT_TCP_NODELAY, 1);
    if (mosquitto_connect(c, broker.host.c_str(), broker.port, 30) != MOSQ_ERR_SUCCESS) {
      std::fprintf(stderr, "bench_fleet: robot %d cannot connect\n", i);
      std::exit(1);
    }
    clients.push_back(c);
  }
  for (int k = 0; k < 5; ++k) {
    for (mosquitto* c : clients) (void)mosquitto_loop(c, 0, 1);
    std::this_thread::sleep_for(20ms);
  }
  std::atomic<std::uint64_t> sent{0};
  const double cpu0_broker = cpu_s_of(broker_pid), cpu0_self = self_cpu_s();
  const auto t0 = steady_clock::now();
  const auto period = duration_cast<steady_clock::duration>(duration<double>(1.0 / hz));
  const auto ticks = static_cast<std::uint64_t>(seconds * hz);
  std::vector<std::thread> workers;
  for (int w = 0; w < threads; ++w) {
    workers.emplace_back([&, w] {
      std::vector<std::string> topics, names;
      for (int i = w; i < robots; i += threads) {
        names.push_back(fmt::format("bench-{}", i));
        topics.push_back(fleet::robot_topics(names.back()).state);
      }
      for (std::uint64_t tick = 0; tick < ticks; ++tick) {
        std::this_thread::sleep_until(t0 + period * tick);
        std::size_t k = 0;
        for (int i = w; i < robots; i += threads, ++k) {
          mosquitto* c = clients[static_cast<std::size_t>(i)];
          const std::string p = state_payload(names[k], tick, now_ns());
          if (mosquitto_publish(c, nullptr, topics[k].c_str(), static_cast<int>(p.size()), p.data(),
                                0, false) == MOSQ_ERR_SUCCESS) {
            ++sent;
          }
          (void)mosquitto_loop(c, 0, 1);
        }
      }
    });
  }
  for (std::thread& t : workers) t.join();
  const double wall = duration<double>(steady_clock::now() - t0).count();
  const double cpu_broker = cpu_s_of(broker_pid) - cpu0_broker;
  const double cpu_self = self_cpu_s() - cpu0_self;
  // the robots' sockets may still hold messages the broker has not read yet: hand them over
  for (int k = 0; k < 3000; ++k) {
    bool pending = false;
    for (mosquitto* c : clients) {
      if (mosquitto_want_write(c)) {
        pending = true;
        (void)mosquitto_loop(c, 0, 1);
      }
    }
    if (!pending) break;
    std::this_thread::sleep_for(10ms);
  }
  // drain: whatever has not arrived once nothing came for a second (at most 30 s) is lost
  for (int waited = 0; waited < 30; ++waited) {
    std::size_t n0 = 0;
    {
      std::lock_guard<std::mutex> lock(dash.mu);
      n0 = dash.latency_ns.size();
    }
    std::this_thread::sleep_for(1s);
    std::lock_guard<std::mutex> lock(dash.mu);
    if (dash.latency_ns.size() == n0) break;
  }
  for (mosquitto* c : clients) {
    mosquitto_disconnect(c);
    mosquitto_destroy(c);
  }
  mosquitto_disconnect(sub);
  mosquitto_loop_stop(sub, false);
  mosquitto_destroy(sub);

  std::lock_guard<std::mutex> lock(dash.mu);
  std::vector<std::int64_t>& l = dash.latency_ns;
  std::sort(l.begin(), l.end());
  const auto pct = [&](double p) {
    return l.empty() ? 0.0
                     : static_cast<double>(
                           l[static_cast<std::size_t>(p * static_cast<double>(l.size() - 1))]) /
                           1e6;
  };
  std::uint64_t received = 0;
  for (std::uint64_t r : dash.received) received += r;
  return Row{robots,
             static_cast<double>(sent) / wall,
             static_cast<double>(received) / wall,
             pct(0.50),
             pct(0.99),
             l.empty() ? 0.0 : static_cast<double>(l.back()) / 1e6,
             sent.load(),
             sent - std::min<std::uint64_t>(sent, received),
             100.0 * cpu_broker / wall,
             100.0 * cpu_self / wall};
}

}  // namespace

int main(int argc, char** argv) {
  std::vector<int> sizes{25, 50, 100, 200};
  double hz = 50.0, seconds = 10.0;
  int threads = 2;
  int pin = 0;
  std::string url;
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string k = argv[i], v = argv[i + 1];
    if (k == "--robots") {
      sizes.clear();
      std::stringstream ss(v);
      for (std::string n; std::getline(ss, n, ',');) sizes.push_back(std::stoi(n));
    } else if (k == "--hz") {
      hz = std::stod(v);
    } else if (k == "--seconds") {
      seconds = std::stod(v);
    } else if (k == "--threads") {
      threads = std::stoi(v);
    } else if (k == "--pin") {
      pin = std::stoi(v);
    } else if (k == "--broker") {
      url = v;
    } else {
      std::fprintf(stderr, "bench_fleet: unknown option '%s'\n", k.c_str());
      return 2;
    }
  }
  (void)fleet::init_mqtt_library();
  std::unique_ptr<scaratwin::ChildProcess> broker;
  fleet::BrokerAddress address;
  pid_t broker_pid = 0;
  if (url.empty()) {
    const fs::path dir =
        fs::temp_directory_path() / fmt::format("scaratwin-bench-fleet-{}", getpid());
    fs::create_directories(dir);
    const int port = scaratwin::test::free_loopback_port();
    auto b = scaratwin::test::start_broker(SCARATWIN_MOSQUITTO, dir, port);
    if (!b) {
      std::fprintf(stderr, "bench_fleet: %s\n", b.error().message.c_str());
      return 1;
    }
    broker = std::move(*b);
    broker_pid = broker->pid();
    if (pin != 0) {
      cpu_set_t broker_cpu, bench_cpu;
      CPU_ZERO(&broker_cpu);
      CPU_SET(0, &broker_cpu);
      CPU_ZERO(&bench_cpu);
      CPU_SET(1, &bench_cpu);
      if (sched_setaffinity(broker_pid, sizeof broker_cpu, &broker_cpu) != 0 ||
          sched_setaffinity(0, sizeof bench_cpu, &bench_cpu) != 0) {
        std::fprintf(stderr, "bench_fleet: --pin: %s\n", std::strerror(errno));
        return 1;
      }
    }
    address.host = "127.0.0.1";
    address.port = static_cast<std::uint16_t>(port);
  } else {
    auto a = fleet::parse_broker_url(url);
    if (!a) {
      std::fprintf(stderr, "bench_fleet: %s\n", a.error().message.c_str());
      return 2;
    }
    address = *a;
    broker_pid = 0;
  }
  fmt::print("fleet load: {} Hz per robot, {} s per size, {} publisher threads, broker {}:{}{}\n",
             hz, seconds, threads, address.host, address.port,
             pin != 0 ? " (broker pinned to CPU 0, robots and dashboard to CPU 1)" : "");
  fmt::print(
      "| robots | offered msg/s | delivered msg/s | p50 ms | p99 ms | max ms | sent | lost "
      "| broker CPU % | bench CPU % |\n|---|---|---|---|---|---|---|---|---|---|\n");
  std::fflush(stdout);
  for (int n : sizes) {
    const Row r = run(address, broker_pid, n, hz, seconds, threads);
    fmt::print("| {} | {:.0f} | {:.0f} | {:.2f} | {:.2f} | {:.1f} | {} | {} | {} | {:.0f} |\n",
               r.robots, r.offered_hz, r.delivered_hz, r.p50_ms, r.p99_ms, r.max_ms, r.sent, r.lost,
               broker_pid > 0 ? fmt::format("{:.0f}", r.broker_cpu) : std::string("-"),
               r.bench_cpu);
    std::fflush(stdout);
  }
  return 0;
}
