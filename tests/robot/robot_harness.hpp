// Test harness for the emulated robot: starts scaratwin-robot, opens its pty exactly as the
// hub opens a real board's serial port (raw mode, input flushed, waits for the hello) and
// connects to its side channel for the truth and for button presses and faults.
#pragma once

#include <sys/types.h>

#include <chrono>
#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

namespace scaratwin::test {

// One side-channel truth sample (keys of the TR line, see src/robot/side_channel.hpp).
struct Truth {
  std::map<std::string, std::string> fields;
  std::int64_t i(const std::string& key) const;
  std::uint64_t u(const std::string& key) const;
  // span_<axis> "first:last" -> pair
  std::pair<std::uint64_t, std::uint64_t> span(const std::string& axis) const;
};

// A parsed ST report: seq t_us z j2 j3 wrist_cdeg grip_cdeg flags queue_free.
struct Report {
  std::int64_t v[9] = {};
  std::int64_t seq() const { return v[0]; }
  std::uint32_t t_us() const { return static_cast<std::uint32_t>(v[1]); }
  std::int64_t z() const { return v[2]; }
  std::int64_t j2() const { return v[3]; }
  std::int64_t j3() const { return v[4]; }
  std::int64_t flags() const { return v[7]; }
  std::int64_t queue_free() const { return v[8]; }
};
std::optional<Report> parse_report(const std::string& line);

class Robot {
 public:
  // Starts the emulator with `args` (e.g. {"--speed", "0"}) and waits for the hello.
  explicit Robot(const std::vector<std::string>& args = {"--speed", "0"});
  ~Robot();
  Robot(const Robot&) = delete;
  Robot& operator=(const Robot&) = delete;

  bool ok() const { return ok_; }
  const std::string& error() const { return error_; }

  // Serial side.
  void send(const std::string& bytes);
  // Next line from the firmware (without '\n'), skipping ST reports unless keep_reports;
  // nullopt on timeout (wall clock).
  std::optional<std::string> line(double timeout_s = 10.0, bool keep_reports = false);
  // Lines until one starts with `prefix` (returned); nullopt on timeout. Skipped lines are
  // appended to *skipped when given.
  std::optional<std::string> wait_for(const std::string& prefix, double timeout_s = 20.0,
                                      std::vector<std::string>* skipped = nullptr);
  // Sends `line` and returns the first non-report reply line.
  std::optional<std::string> request(const std::string& packet, double timeout_s = 10.0);
  // Sends QS and returns the report.
  std::optional<Report> query_state(double timeout_s = 10.0);
  // HM and wait for EV=1=.
  bool home(double timeout_s = 60.0);
  // Pulls the plug: SIGKILL, no orderly exit (what the emulator keeps must already be kept).
  void power_off();

  // Side channel.
  std::string side(const std::string& command, double timeout_s = 10.0);
  Truth truth();

  // Camera (with --plant as-built): one picture of width x height, 8-bit RGB with row 0 at the
  // top, into rgb; returns the FRAME header, or the camera's error (rgb then empty).
  std::string grab(int width, int height, std::vector<std::uint8_t>& rgb, double timeout_s = 20.0);

  // Reports and lines seen so far that callers did not consume.
  std::vector<std::string> reports;

 private:
  std::optional<std::string> read_line_raw(double timeout_s);
  std::optional<std::string> side_line(double timeout_s);

  pid_t pid_ = -1;
  int out_fd_ = -1;  // emulator stdout
  int pty_fd_ = -1;
  int side_fd_ = -1;
  int camera_port_ = -1;
  int camera_fd_ = -1;
  std::string camera_buf_;
  std::string pty_buf_;
  std::string side_buf_;
  bool ok_ = false;
  std::string error_;
};

}  // namespace scaratwin::test
