// scaratwin-robot: the side channel, a line-based TCP server on 127.0.0.1 through which tests,
// the hub and latency measurements see the truth and drive the robot's surroundings.
//
// Emulator -> client, one line per sample, at the client's rate (default 100 Hz, wall clock)
// and on request:
//   TR wall_us=<CLOCK_REALTIME us> mono_us=<CLOCK_MONOTONIC us> sim_us=<emulated time us>
//      z=<steps> j2=<steps> j3=<steps> wrist_cdeg=<c> grip_cdeg=<c> endstops=<mask>
//      buttons=<mask> steps_z=<n> steps_j2=<n> steps_j3=<n> last_step_sim_us=<us>
//      last_rx_sim_us=<us> span_z=<first_us>:<last_us> span_j2=... span_j3=...
//      resets=<n> wdt_resets=<n> boot=<0|1> board_us=<us>
// (one line; z/j2/j3 are the true motor positions counted from the STEP/DIR pins; steps_* the
// STEP pulses seen, including lost ones; last_rx_sim_us the emulated time at which the last
// byte from the host entered the firmware's UART; span_* the emulated times of each axis's
// first and last STEP pulse since the last `mark`, 0:0 when none; resets the external resets
// since power-up (a host opening the port, the reset button), wdt_resets the watchdog's (the
// bootloader leaves for the firmware through one), boot 1 while the MCU runs its bootloader,
// board_us the emulated time since the last reset: the firmware's micros() clock.)
// With the robot as built (--plant as-built) z/j2/j3 are the rotors' true positions and the
// line goes on with: plant=as-built d1_m=<m> q2_rad= q3_rad= q4_rad= (true joints)
// tool_x_m= tool_y_m= tool_z_m= tool_yaw_rad= (true tool) lost_z= lost_j2= lost_j3= (steps
// the motors lost) held=<cube id or -1>; with --plant ideal it ends with plant=ideal.
// Client -> emulator, one command per line, answered "OK <command>" or "ERR <reason>":
//   query | rate <hz> | mark | reset (the board's reset button) | press <button> [ms] | release
//   <button> | cut <ms> [splice] | lose <z|j2|j3> <steps> | corrupt <n> [rx|tx] | endstop <z|j2|j3>
//   <open|closed|ok> (a broken switch or wire reads open or closed whatever its axis does; ok
//   repairs it) | cubes (the physical cubes: "CUBES n id:colour:x_m:y_m:z_m ...") | place
//   <red|green|blue> <x_m> <y_m> [yaw_deg] (an operator puts a cube on the table) | clear (the
//   operator takes every cube away) | pattern <on|off> (the operator lays the printed calibration
//   pattern on the table, or takes it away)
// Buttons: z+ z- j2+ j2- j3+ j3-. The same commands, each prefixed with an emulated time in
// ms, make up a scenario file (--scenario).
//
// SPDX-License-Identifier: GPL-3.0-or-later
// Part of the scaratwin-robot emulator (GPL-3.0-or-later because it links libsimavr).
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "scaratwin/core/result.hpp"

namespace scaratwin::robot {

class SideChannel {
 public:
  // Executes one command line; returns the reply ("OK ..." / "ERR ..."). `client` is the
  // client's index, for per-client commands (rate).
  using CommandHandler = std::function<std::string(const std::string& line, int client)>;

  static Result<SideChannel> listen(std::uint16_t port);
  SideChannel(SideChannel&& other) noexcept;
  SideChannel& operator=(SideChannel&&) = delete;
  SideChannel(const SideChannel&) = delete;
  ~SideChannel();

  std::uint16_t port() const { return port_; }
  int listen_fd() const { return listen_fd_; }
  std::vector<int> client_fds() const;

  // Accepts new clients, reads their commands and answers them.
  void poll(const CommandHandler& handler);
  // Sends `line` to the clients whose rate makes a sample due at `mono_us` (or all with
  // force); `line` ends without '\n'.
  void publish(std::uint64_t mono_us, const std::function<std::string()>& make_line);
  void send_to(int client, const std::string& line);
  void set_rate(int client, double hz);
  // Replies wait (up to 2 s) for a client that is slow to read instead of being cut short:
  // for binary replies that must arrive whole (the camera's frames).
  void set_blocking_replies(bool on) { blocking_ = on; }

 private:
  struct Client {
    int fd = -1;
    std::string in;
    double rate_hz = 100.0;
    std::uint64_t next_us = 0;
  };
  SideChannel() = default;
  void write_all(Client& c, const std::string& data);

  int listen_fd_ = -1;
  std::uint16_t port_ = 0;
  std::vector<Client> clients_;
  bool blocking_ = false;
};

}  // namespace scaratwin::robot
