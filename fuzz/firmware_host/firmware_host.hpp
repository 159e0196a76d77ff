// The firmware's command handling built for the host, for its libFuzzer target
// (fuzz_firmware_commands.cpp) and the replay of the saved corpus in the normal tests
// (tests/firmware/test_firmware_fuzz_corpus.cpp). The firmware's own sources (controller,
// serial rings, step generator, homing, jog, reports, settings) run unchanged against the
// ATmega328P's registers as memory (firmware_host/avr/): the harness feeds the host's bytes
// through the receive interrupt, one byte time (87 us at 115200 baud) apart (a byte 0xff is
// not sent: the host waits 20 ms there, so that an input can let a homing finish), runs the main
// loop, the clock and the 20 kHz step tick, sends what the transmit interrupt gives, and
// closes the endstop switches from the step pulses with the emulator's mechanics
// (src/robot/mechanics.hpp), so homing completes and trajectories run.
//
// The invariants: the firmware's first line is its hello; every line it sends is either a
// packet the host decodes without error (docs/protocol.md section 8), in the companion
// dialect an "error: " line, or with setting 10 = 2 one value of a single-class report
// (`t<us>`, `z`/`y`/`x<steps>`, `w`/`g<cdeg>`: docs/firmware.md); it ends what it sends with
// '\n'; nothing trips ASan or UBSan.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>

namespace scaratwin::fuzz {

// What a firmware fresh from reset sends when `data` comes from the host, with 100 ms more
// after its last byte. Each call starts from reset only where firmware_starts_fresh() is
// true; elsewhere call it once per process.
std::string run_firmware(const std::uint8_t* data, std::size_t size);
bool firmware_starts_fresh();

// The invariants above; empty when they hold, else what broke them.
std::string check_firmware_commands(const std::uint8_t* data, std::size_t size);

}  // namespace scaratwin::fuzz
