// scaratwin flash: writes the firmware into a board through its bootloader with Debian's
// avrdude, verifies it by reading back, and says what the board runs afterwards.
#include <cstdio>

#include <fmt/format.h>

#include "commands.hpp"
#include "scaratwin/config/data_paths.hpp"
#include "scaratwin/hub/flasher.hpp"

namespace scaratwin::cli {

void add_flash_command(CLI::App& app, CommonOptions& common, Runner& run) {
  CLI::App* cmd = app.add_subcommand(
      "flash",
      "write the firmware into the robot's board through its bootloader (avrdude -c arduino, "
      "115200 baud), verify it by reading back, and say what the board runs then");
  struct Args {
    std::string serial = "/dev/ttyACM0";
    std::string hex;
    std::string avrdude = "avrdude";
  };
  auto a = std::make_shared<Args>();
  cmd->add_option("--serial", a->serial, "the board's serial port")->capture_default_str();
  cmd->add_option("--hex", a->hex,
                  "the Intel HEX image to write (default: the packaged Uno firmware)");
  cmd->add_option("--avrdude", a->avrdude, "the avrdude program")->capture_default_str();
  add_common_options(*cmd, common, false);
  cmd->callback([a, &common, &run] {
    run = [a, &common] {
      auto model = load_model(common);
      if (!model) return kExitUsage;
      FlashOptions o;
      o.port = a->serial;
      o.avrdude = a->avrdude;
      o.hex = a->hex.empty() ? firmware_image("uno", "hex") : std::filesystem::path(a->hex);
      o.description_hash = description_hash(*model);
      std::error_code ec;
      if (!std::filesystem::is_regular_file(o.hex, ec)) {
        std::fprintf(stderr, "scaratwin flash: --hex %s: no such file%s\n", o.hex.c_str(),
                     a->hex.empty() ? " (build the target firmware_uno, or pass --hex FILE)" : "");
        return kExitUsage;
      }
      if (!std::filesystem::exists(o.port, ec)) {
        std::fprintf(stderr,
                     "scaratwin flash: --serial %s: no such port (a Uno is usually "
                     "/dev/ttyACM0: ls /dev/ttyACM* /dev/ttyUSB* after plugging it in)\n",
                     o.port.c_str());
        return kExitUsage;
      }
      std::printf("flashing %s into the board on %s with %s\n", o.hex.c_str(), o.port.c_str(),
                  o.avrdude.c_str());
      std::fflush(stdout);
      auto r = flash_board(
          o, [](const std::string& line) { std::fprintf(stderr, "%s\n", line.c_str()); });
      if (!r) {
        std::fprintf(stderr, "scaratwin flash: %s\n", r.error().message.c_str());
        return kExitFailure;
      }
      std::printf("flashed and verified: %ld bytes\n", r->bytes_verified);
      std::printf(
          "the board runs: %s %s, description %s%s\n", r->device.c_str(), r->fw_version.c_str(),
          r->description.empty() ? "(not said)" : r->description.c_str(),
          !r->description.empty() && r->description != o.description_hash
              ? fmt::format(" (this description is {}: a different robot)", o.description_hash)
                    .c_str()
              : "");
      return kExitOk;
    };
  });
}

}  // namespace scaratwin::cli
