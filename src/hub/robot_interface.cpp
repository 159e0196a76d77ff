#include "scaratwin/hub/robot_interface.hpp"

#include <cstdlib>
#include <utility>

#include <fmt/format.h>

#include "hub_internal.hpp"
#include "scaratwin/hub/process.hpp"
#include "scaratwin/transport/serial.hpp"

namespace scaratwin {

namespace tr = transport;
using hub_detail::hub_error;

namespace {

// A robot on a tty: the serial link and its packet channel.
class SerialRobot final : public RobotInterface {
 public:
  SerialRobot(std::string device, unsigned baud) : device_(std::move(device)), baud_(baud) {}
  ~SerialRobot() override { shutdown(); }

  const char* kind() const override { return "serial"; }
  std::string where() const override { return device_; }

  Status configure(const std::shared_ptr<tr::IoThread>& io,
                   std::chrono::milliseconds timeout) override {
    if (link_) return hub_error(fmt::format("the robot on {} is configured already", device_));
    tr::SerialOptions so;
    so.device = device_;
    so.baud = baud_;
    auto link = tr::SerialLink::create(so, io);
    if (!link) return link.error();
    if (Status s = (*link)->wait_connected(timeout); !s) {
      return hub_error(
          fmt::format("physical robot: cannot open {}: {}", device_, s.error().message));
    }
    link_ = std::move(*link);
    channel_ = std::make_unique<tr::RobotChannel>(*link_, tr::robot_channel_defaults());
    return Ok{};
  }

  tr::RobotChannel& channel() override { return *channel_; }

  tr::LinkCounters counters() const override {
    return link_ ? link_->counters() : tr::LinkCounters{};
  }

  void shutdown() override {
    channel_.reset();  // it holds the link's handlers
    link_.reset();
  }

  void set_device(std::string device) { device_ = std::move(device); }

 private:
  std::string device_;
  unsigned baud_;
  std::unique_ptr<tr::SerialLink> link_;
  std::unique_ptr<tr::RobotChannel> channel_;
};

// The emulator as a child process, and a serial robot on the pty it prints.
class EmulatedRobot final : public RobotInterface {
 public:
  explicit EmulatedRobot(EmulatedRobotOptions options)
      : options_(std::move(options)), serial_("", options_.baud) {}
  ~EmulatedRobot() override { shutdown(); }

  const char* kind() const override { return "emulated"; }
  std::string where() const override {
    return pty_.empty() ? std::string{"the emulated robot (not started)"} : pty_;
  }

  Status configure(const std::shared_ptr<tr::IoThread>& io,
                   std::chrono::milliseconds timeout) override {
    if (process_) return hub_error("the emulated robot is configured already");
    const auto exe =
        options_.executable.empty() ? sibling_executable("scaratwin-robot") : options_.executable;
    // the emulator loads the firmware and opens its pty before it says it is ready
    auto started = start_emulator(exe, options_.args, options_.log,
                                  std::max(timeout, std::chrono::milliseconds(30000)));
    if (!started) {
      return hub_error(
          fmt::format("emulated robot ({}): {}", exe.string(), started.error().message));
    }
    process_ = std::move(started->process);
    pty_ = started->ready.pty;
    side_port_ = started->ready.side_port;
    serial_.set_device(pty_);
    return serial_.configure(io, timeout);
  }
  std::uint16_t side_channel_port() const override { return side_port_; }

  tr::RobotChannel& channel() override { return serial_.channel(); }
  tr::LinkCounters counters() const override { return serial_.counters(); }

  void shutdown() override {
    serial_.shutdown();
    if (process_) process_->stop();
  }

 private:
  EmulatedRobotOptions options_;
  SerialRobot serial_;
  std::unique_ptr<ChildProcess> process_;
  std::string pty_;
  std::uint16_t side_port_ = 0;
};

}  // namespace

std::unique_ptr<RobotInterface> serial_robot(std::string device, unsigned baud) {
  return std::make_unique<SerialRobot>(std::move(device), baud);
}

std::unique_ptr<RobotInterface> emulated_robot(EmulatedRobotOptions options) {
  return std::make_unique<EmulatedRobot>(std::move(options));
}

}  // namespace scaratwin
