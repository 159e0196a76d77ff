// scaratwin-robot: the AVR microcontroller, emulated by libsimavr. Loads the firmware ELF,
// exposes pin changes and pin inputs as callbacks, and connects UART0 to a byte queue with
// simavr's XON/XOFF back-pressure, so bytes enter the firmware at the baud rate it configured.
// simavr 1.6 pitfalls handled here: INT0/INT1 strict level triggering is turned off (it slows
// the run fivefold), the UART's stdio and poll-sleep flags are cleared, and simavr's own sleep
// callback is replaced: the caller paces the run (simavr only syncs to the wall clock while the
// firmware sleeps, and then by calling usleep).
//
// SPDX-License-Identifier: GPL-3.0-or-later
// Part of the scaratwin-robot emulator, which links libsimavr (GPL-3.0) and is therefore
// distributed under the GNU General Public License, version 3 or later.
#pragma once

#include <cstdint>
#include <deque>
#include <functional>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "scaratwin/core/result.hpp"

struct avr_t;
struct avr_irq_t;
struct elf_firmware_t;

namespace scaratwin::robot {

class AvrMachine {
 public:
  using PinCallback = std::function<void(bool level)>;
  using ByteCallback = std::function<void(std::uint8_t byte)>;

  // Loads `elf_path` into a new `mcu` ("atmega328p") running at `frequency_hz`; an empty path
  // leaves the flash erased (0xff), as on a new chip.
  static Result<std::unique_ptr<AvrMachine>> load(const std::string& elf_path,
                                                  const std::string& mcu,
                                                  std::uint32_t frequency_hz);
  ~AvrMachine();
  AvrMachine(const AvrMachine&) = delete;
  AvrMachine& operator=(const AvrMachine&) = delete;

  // Calls `cb` whenever the output level of pin `bit` of `port` ('B', 'C', 'D') changes.
  void watch_pin(char port, int bit, PinCallback cb);
  // Drives an input pin from outside (a switch, a button). simavr 1.6 overwrites the input
  // bits of a port's PIN register whenever the firmware writes that port's PORT register (a
  // servo pulse on port C, say); the level is asserted again after every such write.
  void drive_pin(char port, int bit, bool level);
  // Every byte the firmware transmits on UART0.
  void on_uart_output(ByteCallback cb);
  // Queues a byte for the firmware's UART0 receiver.
  void uart_send(std::uint8_t byte);
  std::size_t uart_pending() const { return to_avr_.size(); }

  // The MCU's EEPROM (1 KiB on the ATmega328P): its bytes now, and writing them (at power-up,
  // before the firmware runs, to stand for what an earlier session left). set_eeprom() is
  // false when the size is not the MCU's.
  // The span points into simavr's own EEPROM memory (valid as long as the machine).
  std::span<const std::uint8_t> eeprom() const;
  bool set_eeprom(std::span<const std::uint8_t> bytes);

  // The MCU's flash (32 KiB on the ATmega328P), byte-addressed: what is programmed now (the
  // bootloader writes it with SPM) and programming it from outside (at power-up, as an ISP
  // programmer would). set_flash() is false when the size is not the MCU's; write_flash()
  // when the bytes do not fit.
  // The span points into simavr's own flash memory (valid as long as the machine).
  std::span<const std::uint8_t> flash() const;
  bool set_flash(std::span<const std::uint8_t> bytes);
  bool write_flash(std::uint32_t byte_address, std::span<const std::uint8_t> bytes);
  // The BOOTRST fuse: every reset, power-up included, starts at `byte_address` (the boot
  // section, where a bootloader lives) instead of 0. Before the first run_until().
  void set_reset_vector(std::uint32_t byte_address);
  // Whether the program counter is in the boot section (false without a reset vector).
  bool in_boot_section() const;
  // The RESET pin pulled low and released (what a Uno's USB chip does when the host opens the
  // port): the MCU restarts at its reset vector with EXTRF in MCUSR, its registers and I/O in
  // their reset state; flash, EEPROM and the emulated clock go on.
  void reset_external();
  // A new board (its application erased): optiboot leaves for the application, which runs
  // through the erased flash into the bootloader again, a return address deeper on the stack
  // each pass (about 1 ms). A chip goes on looping; simavr stops, and writes beyond its RAM,
  // once the stack leaves the RAM. This starts such a board over (a power-on reset) while its
  // stack is still in RAM; true when it did. Call it at least every 100 ms of emulated time.
  bool restart_blank_loop();
  // Resets since power-up: every one (the watchdog's too), and the external ones.
  std::uint32_t resets() const { return resets_; }
  std::uint32_t external_resets() const { return external_resets_; }
  // Emulated microseconds since the last reset (power-up included): the clock the firmware's
  // micros() counts, which starts over at every reset.
  std::uint64_t us_since_reset() const {
    return (cycle() - last_reset_cycle_) * 1000000ULL / frequency_;
  }

  // Runs until the cycle counter reaches `cycle` (the last instruction may end a few cycles
  // past it); while the firmware sleeps its idle cycles are skipped, not emulated, and the
  // skip too ends at `cycle`. False if the firmware crashed or stopped.
  bool run_until(std::uint64_t cycle);
  std::uint64_t cycle() const;
  // While the firmware sleeps: the cycle of its next timer event (a timer's compare or
  // overflow, a UART byte), the earliest it can wake by itself; nothing changes before then
  // unless the caller sends a byte or drives a pin. cycle() while it runs.
  std::uint64_t wake_cycle() const;
  std::uint32_t frequency() const { return frequency_; }
  double sim_seconds() const { return static_cast<double>(cycle()) / frequency_; }
  std::uint64_t sim_us() const { return cycle() * 1000000ULL / frequency_; }

  // A statistical CPU profile of the firmware: samples the program counter every
  // `period_cycles` (sleeping counts apart). profile_table() names the functions from the
  // ELF's symbols and gives each one's share of the CPU, the largest first.
  void start_profile(std::uint32_t period_cycles);
  std::string profile_table(int rows) const;
  void profile_sample(bool sleeping, std::uint32_t pc);  // called by the sampling timer
  std::uint32_t profile_period() const { return profile_period_; }

 private:
  AvrMachine() = default;
  void feed_uart();
  static void pin_hook(avr_irq_t* irq, std::uint32_t value, void* param);
  static void uart_out_hook(avr_irq_t* irq, std::uint32_t value, void* param);
  static void xon_hook(avr_irq_t* irq, std::uint32_t value, void* param);
  static void xoff_hook(avr_irq_t* irq, std::uint32_t value, void* param);
  static void port_write_hook(avr_irq_t* irq, std::uint32_t value, void* param);
  static void reset_hook(avr_t* avr);
  void reassert(char port);
  // after any reset: simavr dropped every cycle timer and the UART's state
  void after_reset();

  avr_t* avr_ = nullptr;
  elf_firmware_t* fw_ = nullptr;  // owned: simavr allocates its buffers, freed with it
  std::uint32_t frequency_ = 16000000;
  std::vector<std::unique_ptr<PinCallback>> pin_callbacks_;
  ByteCallback uart_out_;
  std::deque<std::uint8_t> to_avr_;
  bool xoff_ = false;
  avr_irq_t* uart_in_ = nullptr;
  // Input levels driven from outside, per port ('B', 'C', 'D'): bit mask and levels.
  struct Driven {
    std::uint8_t mask = 0;
    std::uint8_t level = 0;
    bool hooked = false;
  };
  Driven driven_[3];
  bool reasserting_ = false;
  void (*core_reset_)(avr_t*) = nullptr;  // the core's own reset hook, called first
  std::uint32_t resets_ = 0;
  std::uint32_t external_resets_ = 0;
  bool reset_seen_ = false;             // a reset since the last after_reset()
  std::uint64_t reset_cycle_ = 0;       // the cycle it happened at
  std::uint64_t last_reset_cycle_ = 0;  // the cycle of the latest reset
  std::uint32_t profile_period_ = 0;
  std::uint64_t profile_sleep_ = 0;
  std::vector<std::uint32_t> profile_pc_;  // samples per word address
};

}  // namespace scaratwin::robot
