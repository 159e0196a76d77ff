// Benchmarks of the emulated physical link (the firmware in scaratwin-robot, paced to real
// time, through its pty at 115200 baud):
//  1. command round trip PI -> AK=PI (p50 / p99) beside the time the bytes need on the wire;
//  2. the highest state-report rate (SR) that arrives without a sequence gap.
// Usage: bench_robot [pings] [seconds per rate]
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "robot_harness.hpp"

using scaratwin::test::parse_report;
using scaratwin::test::Robot;

namespace {

// The Uno at 115200 runs U2X with UBRR 16: 16 MHz / 8 / 17 = 117,647 baud, 10 bits per byte
// on a real line (8N1); simavr 1.6 spends 11 bit times per byte.
constexpr double kBaud = 16e6 / 8.0 / 17.0;
double wire_ms(std::size_t bytes, double bits) {
  return static_cast<double>(bytes) * bits / kBaud * 1e3;
}

double percentile(std::vector<double> v, double p) {
  std::sort(v.begin(), v.end());
  return v[static_cast<std::size_t>(p * static_cast<double>(v.size() - 1))];
}

}  // namespace

int main(int argc, char** argv) {
  const int pings = argc > 1 ? std::atoi(argv[1]) : 500;
  const double seconds = argc > 2 ? std::atof(argv[2]) : 4.0;
  std::setvbuf(stdout, nullptr, _IOLBF, 0);
  Robot robot({"--speed", "1"});
  if (!robot.ok()) {
    std::fprintf(stderr, "bench_robot: %s\n", robot.error().c_str());
    return 1;
  }
  if (robot.request("SR=0=\n").value_or("") != "AK=SR=0=") {
    std::fprintf(stderr, "bench_robot: no answer to SR\n");
    return 1;
  }
  std::fprintf(stderr, "bench_robot: emulator up, measuring\n");
  while (robot.line(0.3, true)) {
  }
  // 1. round trip
  std::vector<double> rtt_ms;
  std::size_t bytes = 0;
  for (int k = 0; k < pings; ++k) {
    const std::string req = "PI=" + std::to_string(100000 + k) + "=\n";
    const std::string want = "AK=PI=" + std::to_string(100000 + k) + "=";
    const auto t0 = std::chrono::steady_clock::now();
    auto reply = robot.request(req);
    const auto t1 = std::chrono::steady_clock::now();
    if (!reply || *reply != want) {
      std::fprintf(stderr, "bench_robot: bad reply to %s", req.c_str());
      return 1;
    }
    rtt_ms.push_back(std::chrono::duration<double, std::milli>(t1 - t0).count());
    bytes = req.size() + want.size() + 1;
  }
  std::printf("## command round trip over the emulated serial line (115200 baud, paced 1x)\n\n");
  std::printf(
      "| command | bytes | wire time 8N1 / simavr (ms) | p50 (ms) | p99 (ms) | max (ms) |\n");
  std::printf("|---|---|---|---|---|---|\n");
  std::printf(
      "| PI=100000= -> AK=PI=100000= (%d round trips) | %zu | %.2f / %.2f | %.2f | %.2f | "
      "%.2f |\n\n",
      pings, bytes, wire_ms(bytes, 10), wire_ms(bytes, 11), percentile(rtt_ms, 0.5),
      percentile(rtt_ms, 0.99), percentile(rtt_ms, 1.0));

  // 2. report rate without loss
  std::printf("## state reports: highest rate without a sequence gap (%.0f s per rate)\n\n",
              seconds);
  std::printf(
      "| requested (Hz) | received | gaps (lost) | device rate (Hz) | bytes per report | "
      "wire limit 8N1 / simavr (Hz) |\n|---|---|---|---|---|---|\n");
  int best = 0;
  for (int rate : {100, 150, 200, 250, 275, 300, 350, 400, 500}) {
    if (robot.request("SR=" + std::to_string(rate) + "=\n").value_or("") !=
        "AK=SR=" + std::to_string(rate) + "=") {
      return 1;
    }
    std::vector<scaratwin::test::Report> reps;
    std::size_t report_bytes = 0;
    long lost = 0;
    const auto t0 = std::chrono::steady_clock::now();
    while (std::chrono::steady_clock::now() - t0 < std::chrono::duration<double>(seconds)) {
      auto l = robot.line(2.0, true);
      if (!l) break;
      auto r = parse_report(*l);
      if (!r) continue;
      if (!reps.empty()) lost += (r->seq() - reps.back().seq() + 65536) % 65536 - 1;
      reps.push_back(*r);
      report_bytes = std::max(report_bytes, l->size() + 1);
    }
    robot.request("SR=0=\n");
    while (robot.line(0.3, true)) {
    }
    const double dev_s =
        reps.size() > 1 ? static_cast<std::uint32_t>(reps.back().t_us() - reps.front().t_us()) / 1e6
                        : 1.0;
    const double limit = kBaud / 10.0 / static_cast<double>(report_bytes);
    std::printf("| %d | %zu | %ld | %.1f | %zu | %.0f / %.0f |\n", rate, reps.size(), lost,
                static_cast<double>(reps.size() - 1) / dev_s, report_bytes, limit,
                limit * 10.0 / 11.0);
    if (lost == 0 && reps.size() > 10) best = std::max(best, rate);
  }
  std::printf("\nhighest rate without loss: %d Hz\n", best);
  return 0;
}
