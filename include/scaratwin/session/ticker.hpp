// The demo's progress line: while a phase runs, once a second, the tool as the robot reports
// it and the mirror's counters.
#pragma once

#include <atomic>
#include <chrono>
#include <string>
#include <thread>

#include <fmt/format.h>

#include "scaratwin/core/units.hpp"
#include "scaratwin/hub/hub.hpp"
#include "scaratwin/kinematics/kinematics.hpp"
#include "scaratwin/session/say.hpp"

namespace scaratwin::session {

// Says a status line every second while a phase runs.
class Ticker {
 public:
  Ticker(Hub& hub, std::string phase, Say say)
      : hub_(hub), phase_(std::move(phase)), say_(std::move(say)) {
    thread_ = std::thread([this] {
      const auto start = std::chrono::steady_clock::now();
      while (!stop_) {
        std::this_thread::sleep_for(std::chrono::milliseconds(100));
        if (std::chrono::steady_clock::now() - last_ < std::chrono::seconds(1)) continue;
        last_ = std::chrono::steady_clock::now();
        const MirrorCounters c = hub_.mirror_counters();
        const PhysicalState p = hub_.physical();
        const ToolPose tool = forward(hub_.model(), p.q);
        say_(fmt::format(
            "    {:<10} {:5.1f} s  tool ({:6.1f}, {:6.1f}, {:6.1f}) mm  mirror {} frames, "
            "{} lost, latency {:.2f} ms",
            phase_, std::chrono::duration<double>(last_ - start).count(), m_to_mm(tool.x_m),
            m_to_mm(tool.y_m), m_to_mm(tool.z_m), c.applied, c.lost, c.last_latency_ms));
      }
    });
  }
  ~Ticker() {
    stop_ = true;
    thread_.join();
  }

 private:
  Hub& hub_;
  std::string phase_;
  Say say_;
  std::atomic<bool> stop_{false};
  std::chrono::steady_clock::time_point last_ = std::chrono::steady_clock::now();
  std::thread thread_;
};

}  // namespace scaratwin::session
