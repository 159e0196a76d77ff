// scaratwin-robot: the emulated physical robot. Runs the firmware ELF in simavr, wires its
// pins to the mechanics model (STEP/DIR counting, servo decoding, endstops, jog buttons), its
// UART0 to a pseudo-terminal and the truth to the side channel, and paces the emulated time
// to the wall clock (times --speed; 0 runs as fast as possible). Fault injection: a cut link,
// lost steps, corrupted bytes; jog button presses from the side channel or a scenario file.
//
// SPDX-License-Identifier: GPL-3.0-or-later
// Part of the scaratwin-robot emulator, which links libsimavr (GPL-3.0) and is therefore
// distributed under the GNU General Public License, version 3 or later.
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "avr_machine.hpp"
#include "mechanics.hpp"
#include "pty_link.hpp"
#include "scaratwin/core/result.hpp"
#include "scaratwin/plant/plant.hpp"
#include "scaratwin/plant/plant_camera.hpp"
#include "side_channel.hpp"

namespace scaratwin::robot {

struct EmulatorOptions {
  // The firmware ELF, programmed into the flash at power-up as an ISP programmer would; empty:
  // the flash as the flash file holds it (or erased, on a new board).
  std::string firmware;
  // The bootloader (Intel HEX, e.g. Debian's optiboot_atmega328.hex) in the boot section, where
  // every reset starts (the BOOTRST fuse); empty: none, resets start the firmware at 0.
  std::string bootloader;
  // Non-volatile flash: the whole flash loaded from this file at power-up when no firmware is
  // given (absent: a new board) and written back (by rename) whenever the bootloader changed
  // it, as EEPROM is. Empty: the flash lives as long as the run.
  std::string flash_file;
  // A Uno's auto-reset: a host opening the serial port (the pty's slave side) resets the MCU,
  // as the USB chip's DTR line does. False: the board with its auto-reset cut (a 10 uF
  // capacitor RESET-GND); the port is then held open and never resets the MCU.
  bool auto_reset = true;
  std::string mcu = "atmega328p";
  double speed = 1.0;       // emulated seconds per wall second; 0 = unpaced
  double duration_s = 0.0;  // stop after this much emulated time; 0 = run until signalled
  std::uint16_t side_port = 0;
  std::string scenario;     // scenario file
  std::string pty_symlink;  // optional stable name for the pty
  MechanicsConfig mechanics;
  // The physical world behind the pins: empty = the ideal robot (STEP pulses counted, the
  // robot exactly its description); set = the robot as built (plant.hpp).
  struct PlantSetup {
    RobotModel description;
    AsBuilt as_built;
    plant::PlantOptions options;
  };
  std::optional<PlantSetup> plant;
  // The real camera over the physical table (as-built only): a TCP port on 127.0.0.1 (0 = any
  // free one, -1 = no camera). "grab <w> <h>" is answered "FRAME <n> <board_us> <w> <h> <bytes>"
  // and that many bytes of RGB (row 0 at the top), then a newline.
  int camera_port = 0;
  std::uint32_t profile_cycles = 0;  // > 0: sample the firmware's program counter this often
  // Non-volatile EEPROM: loaded from this file at power-up (absent: an erased EEPROM, all
  // 0xff) and written back (whole, by rename) whenever the firmware has changed it, so the
  // settings survive the emulator's end however it ends, as they survive a board's power
  // cycle. Empty: the EEPROM lives as long as the run.
  std::string eeprom_file;
};

// One timed command of a scenario file: "<t_ms> <command>".
struct ScenarioStep {
  double t_s = 0.0;
  std::string command;
};
Result<std::vector<ScenarioStep>> parse_scenario(const std::string& text);

class Emulator {
 public:
  static Result<std::unique_ptr<Emulator>> create(const EmulatorOptions& options);
  // Runs until the duration passes, `stop` becomes true or the firmware crashes.
  Status run(const volatile bool& stop);

  const PtyLink& pty() const { return pty_; }
  const SideChannel& side() const { return side_; }
  // The camera's port, 0 when there is none.
  std::uint16_t camera_port() const { return camera_port_ ? camera_port_->port() : 0; }
  // Executes one side-channel / scenario command; returns the reply line.
  std::string command(const std::string& line, int client);
  std::string truth_line() const;
  std::string cubes_line() const;  // the physical cubes: "CUBES n id:colour:x:y:z ..."
  const plant::Plant* physical() const { return plant_.get(); }
  // The firmware CPU profile (EmulatorOptions::profile_cycles), largest share first.
  std::string profile_table() const { return avr_->profile_table(30); }

 private:
  Emulator(const EmulatorOptions& o, std::unique_ptr<AvrMachine> m, PtyLink pty, SideChannel side);
  void wire_pins();
  void update_endstops();
  void set_button(int button, bool pressed);
  void from_host(const std::vector<std::uint8_t>& bytes);
  void to_host(std::uint8_t byte);
  bool link_cut() const;
  Status load_eeprom();
  void save_eeprom_if_changed();
  Status load_flash();
  void save_flash_if_changed();
  void watch_host(double now_s);
  // An external reset at emulated time now_s (a host's open, the reset button).
  void reset_board(double now_s);

  EmulatorOptions options_;
  std::unique_ptr<AvrMachine> avr_;
  PtyLink pty_;
  SideChannel side_;
  Mechanics mech_;
  std::unique_ptr<plant::Plant> plant_;
  std::optional<SideChannel> camera_port_;
  std::unique_ptr<plant::PlantCamera> camera_;
  std::string camera_command(const std::string& line);
  std::uint8_t endstops_driven_ = 0xff;
  std::uint8_t buttons_ = 0;
  std::array<double, 6> release_at_s_{};  // timed presses: emulated time of the release
  double cut_until_s_ = 0.0;
  // a splice cut (`cut <ms> splice`): armed, it starts right after a state report's t_us
  // field and ends, once its time is up, at the same place in a later report
  enum class Splice { kNone, kArmed, kCutting };
  Splice splice_ = Splice::kNone;
  double splice_ms_ = 0.0;
  double splice_until_s_ = 0.0;
  // the line the firmware is sending: whether it is a state report (ST), the delimiters so
  // far, the last byte
  std::uint32_t tx_len_ = 0;
  std::uint32_t tx_delims_ = 0;
  bool tx_state_report_ = false;
  std::uint8_t tx_first_ = 0;
  std::uint8_t tx_prev_ = 0;
  std::uint32_t corrupt_rx_ = 0;
  std::uint32_t corrupt_tx_ = 0;
  std::uint64_t last_rx_sim_us_ = 0;
  // broken switches (side channel `endstop`): bits forced, and the level they are forced to
  std::uint8_t endstop_forced_mask_ = 0;
  std::uint8_t endstop_forced_closed_ = 0;
  std::vector<std::uint8_t> eeprom_saved_;  // the EEPROM as last loaded or written
  std::vector<std::uint8_t> flash_saved_;   // the flash as last loaded or written
  bool boot_ran_ = false;                   // the bootloader ran since the flash was last compared
  double flash_checked_s_ = 0.0;            // emulated time of that comparison
  bool host_present_ = false;               // a host has the port open (always, without auto-reset)
  bool drop_backlog_ = false;               // a reset: the pacing forgets how far behind it is
  double boot_until_s_ = 0.05;  // drive the switches again until then (the firmware booting)
  std::vector<ScenarioStep> scenario_;
  std::size_t scenario_next_ = 0;
};

}  // namespace scaratwin::robot
