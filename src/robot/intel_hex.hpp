// scaratwin-robot: Intel HEX images (what avrdude and the Arduino tools write), read into a
// flash image so the emulated board can hold a bootloader: data records (00), end (01) and the
// segment and linear address records (02, 04); start-address records (03, 05) are skipped, as
// an AVR has no use for them. Every record's checksum is checked.
//
// SPDX-License-Identifier: GPL-3.0-or-later
// Part of the scaratwin-robot emulator (GPL-3.0-or-later because it links libsimavr).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "scaratwin/core/result.hpp"

namespace scaratwin::robot {

// One run of bytes at a byte address.
struct HexChunk {
  std::uint32_t address = 0;
  std::vector<std::uint8_t> bytes;
};

// Parses the text of an Intel HEX file; an error names the line and what is wrong with it.
Result<std::vector<HexChunk>> parse_intel_hex(const std::string& text);
// Reads and parses a file.
Result<std::vector<HexChunk>> read_intel_hex(const std::string& path);

}  // namespace scaratwin::robot
