// Writing a firmware into a board the way a real Uno gets it: Debian's avrdude talks STK500 to
// the bootloader (optiboot) on the serial port, writes the Intel HEX image, reads it back to
// verify, and the board then starts the new firmware, whose hello says what it is.
#pragma once

#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include "scaratwin/core/result.hpp"

namespace scaratwin {

struct FlashOptions {
  std::string port;                    // the board's serial device (/dev/ttyACM0, a pty)
  std::filesystem::path hex;           // Intel HEX image to write
  std::string avrdude = "avrdude";     // the programmer program (found on PATH)
  std::string part = "m328p";          // avrdude's -p (the Uno's ATmega328P)
  std::string programmer = "arduino";  // avrdude's -c (STK500 v1 as optiboot speaks it)
  std::string device = "scara-uno";    // the device name the board's firmware says hello with
  int baud = 115200;                   // optiboot's rate on a Uno
  double avrdude_timeout_s = 180.0;    // the whole write and verify
  // The hello after the write: the host's description hash (8 hex digits) sent in it, so the
  // firmware answers with its own; empty: a version-1 hello.
  std::string description_hash;
  double hello_timeout_s = 10.0;  // the bootloader's wait, the firmware's start
};

struct FlashResult {
  std::vector<std::string> avrdude_output;  // avrdude's own lines
  long bytes_verified = 0;                  // "N bytes of flash verified"
  // from the firmware's hello once the board runs it
  std::string device;       // e.g. "scara-uno"
  std::string fw_version;   // e.g. "0.1.0"
  std::string description;  // its description hash (empty: not said)
};

// Runs avrdude against options.port and then waits for the new firmware's hello. An image of
// our firmware for another board is refused before avrdude runs. An error quotes avrdude's own
// message (a corrupt file, an address beyond the MCU's flash, no bootloader answering) and
// says what the board runs afterwards, or says that the board never said hello. `progress` gets
// each line avrdude prints (may be empty).
Result<FlashResult> flash_board(const FlashOptions& options,
                                const std::function<void(const std::string&)>& progress = {});

// The device name our firmware images carry ("scara-uno", "scara-mega"), found in an Intel HEX
// text; empty for another program.
std::string firmware_device_in_hex(const std::string& hex_text);

// Opens a board's serial port (raw, 115200 baud, input flushed), sends a hello every 500 ms
// until the firmware answers, and returns the fields of its HI reply after the code (protocol
// version, device, firmware version, [description]). `hash`: as in FlashOptions.
Result<std::vector<std::string>> board_hello(const std::string& port, const std::string& hash,
                                             double timeout_s);

}  // namespace scaratwin
