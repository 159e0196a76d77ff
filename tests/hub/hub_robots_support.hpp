// What the hub's robot-interface tests share (test_hub_robots.cpp, test_hub_workcell.cpp): the
// programs and files they start, the paper's description, and the fake robot as the hub's
// robot interface.
#pragma once

#include <filesystem>
#include <memory>
#include <string>

#include <gtest/gtest.h>

#include "fake_robot.hpp"
#include "hub_test_support.hpp"
#include "scaratwin/config/robot_config.hpp"
#include "scaratwin/hub/robot_interface.hpp"
#include "scaratwin/kinematics/robot_model.hpp"

namespace scaratwin::robots_test {

namespace fs = std::filesystem;
using fake::FakeRobot;

inline const fs::path kBin = SCARATWIN_BIN_DIR;
inline const fs::path kConfig = SCARATWIN_CONFIG_FILE;
inline const fs::path kWorkcell = SCARATWIN_WORKCELL_FILE;

inline fs::path fresh_dir(const char* name) {
  return test::fresh_dir(std::string("robots-") + name);
}

inline RobotModel paper_model() {
  auto m = load_robot_config(kConfig);
  if (!m) ADD_FAILURE() << m.error().message;
  return *m;
}

// The fake as the hub's robot: a serial robot on the fake's pty, of kind "fake", that keeps
// the fake running while the hub holds it.
class FakeInterface final : public RobotInterface {
 public:
  explicit FakeInterface(std::shared_ptr<FakeRobot> robot)
      : robot_(std::move(robot)), serial_(serial_robot(robot_->device_path())) {}
  const char* kind() const override { return "fake"; }
  std::string where() const override { return serial_->where(); }
  Status configure(const std::shared_ptr<transport::IoThread>& io,
                   std::chrono::milliseconds timeout) override {
    return serial_->configure(io, timeout);
  }
  transport::RobotChannel& channel() override { return serial_->channel(); }
  transport::LinkCounters counters() const override { return serial_->counters(); }
  void shutdown() override { serial_->shutdown(); }

 private:
  std::shared_ptr<FakeRobot> robot_;
  std::unique_ptr<RobotInterface> serial_;
};

}  // namespace scaratwin::robots_test
