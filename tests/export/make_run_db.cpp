// Writes a small twin database the way the hub records one (TwinDb's API): a demo session with
// a mirror phase (physical samples at 200 Hz, their mirrored virtual samples and per-frame
// latencies, an event) and a control phase (a plan, physical and true samples, commands, a
// camera image, a desync event, metrics). The MCAP export's end-to-end test reads it.
//
// Usage: make_run_db DB
#include <cmath>
#include <cstdio>
#include <string>

#include "scaratwin/hub/twin_db.hpp"

using namespace scaratwin;

namespace {

// a 1x1 PNG (67 bytes: its base64 ends in "==")
const unsigned char kPng[] = {
    0x89, 0x50, 0x4E, 0x47, 0x0D, 0x0A, 0x1A, 0x0A, 0x00, 0x00, 0x00, 0x0D, 0x49, 0x48,
    0x44, 0x52, 0x00, 0x00, 0x00, 0x01, 0x00, 0x00, 0x00, 0x01, 0x08, 0x06, 0x00, 0x00,
    0x00, 0x1F, 0x15, 0xC4, 0x89, 0x00, 0x00, 0x00, 0x0A, 0x49, 0x44, 0x41, 0x54, 0x78,
    0x9C, 0x63, 0x00, 0x01, 0x00, 0x00, 0x05, 0x00, 0x01, 0x0D, 0x0A, 0x2D, 0xB4, 0x00,
    0x00, 0x00, 0x00, 0x49, 0x45, 0x4E, 0x44, 0xAE, 0x42, 0x60, 0x82};

JointVector pose(double t) {
  return {0.08 + 0.02 * std::sin(t), 0.7 * std::sin(0.5 * t), 0.9 * std::sin(0.3 * t + 0.2),
          1.0 + 0.5 * std::sin(t / 7.0)};
}

bool ok(const Status& s) {
  if (!s) std::fprintf(stderr, "make_run_db: %s\n", s.error().message.c_str());
  return static_cast<bool>(s);
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: make_run_db DB\n");
    return 2;
  }
  std::remove(argv[1]);
  auto db = TwinDb::open(argv[1]);
  if (!db) {
    std::fprintf(stderr, "make_run_db: %s\n", db.error().message.c_str());
    return 1;
  }
  TwinDb& d = **db;
  const int64_t demo = *d.begin_run("demo", "mcap fixture");

  // the mirror: a physical sample every 5 ms, mirrored 3 ms later
  const int64_t mirror = *d.begin_run("mirror", "mirror phase", demo);
  const int64_t rx0_us = 912345678;
  for (int i = 0; i < 1500; ++i) {
    const double t_s = 0.005 * i + 0.0001 * (i % 3);
    const JointVector q = pose(t_s);
    const int64_t rx_us = rx0_us + static_cast<int64_t>(std::llround(t_s * 1e6));
    if (!ok(d.add_sample(mirror, SampleSource::kPhysical, {t_s, i + 100, q, 10.0}))) return 1;
    if (!ok(d.add_sample(mirror, SampleSource::kVirtual, {t_s + 0.003, i + 100, q, 10.0}))) {
      return 1;
    }
    if (!ok(d.add_latency(mirror, {i + 100, 5000 * i, rx_us, rx_us + 3000}))) return 1;
  }
  if (!ok(d.add_event(mirror, 0.0, "homing", "all axes homed"))) return 1;
  if (!ok(d.end_run(mirror, "ok", 7.5))) return 1;

  // the control: the plan, the robot's report and the emulator's truth
  const int64_t control = *d.begin_run("control", "to a cube", demo);
  for (int i = 0; i < 60; ++i) {
    if (!ok(d.add_sample(control, SampleSource::kPlanned, {0.05 * i, -1, pose(0.05 * i), 0.0}))) {
      return 1;
    }
  }
  for (int i = 0; i < 600; ++i) {
    const double t_s = 0.005 * i;
    if (!ok(d.add_sample(control, SampleSource::kPhysical, {t_s, i, pose(t_s), 60.0}))) return 1;
    if (i % 6 == 0 &&
        !ok(d.add_sample(control, SampleSource::kTruth, {t_s, -1, pose(t_s + 0.001), 60.0}))) {
      return 1;
    }
  }
  if (!ok(d.add_command(control, 0.0, "serial", "TJ=1=60="))) return 1;
  if (!ok(d.add_command(control, 0.1, "tcp", "GS,1,"))) return 1;
  if (!ok(d.add_image(control, 0.2, "overhead",
                      std::string(reinterpret_cast<const char*>(kPng), sizeof kPng)))) {
    return 1;
  }
  if (!ok(d.add_event(control, 1.5, "desync", "tool 3.2 mm off the plan, \"quoted\""))) return 1;
  if (!ok(d.add_metric(control, "tool_error_mean", 0.0012, "m"))) return 1;
  if (!ok(d.add_metric(control, "duration", 3.0, "s"))) return 1;
  if (!ok(d.end_run(control, "ok", 3.0))) return 1;
  if (!ok(d.add_metric(demo, "mirror_latency_mean", 3.0, "ms"))) return 1;
  if (!ok(d.end_run(demo, "ok", 11.0))) return 1;
  return ok(d.flush()) ? 0 : 1;
}
