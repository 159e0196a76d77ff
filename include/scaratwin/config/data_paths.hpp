// Where scaratwin's data files are: the robot descriptions, the firmware images (ELF and HEX per
// board) and the built browser page.
//
// An executable run from the build tree it was built in (<build>/bin) takes them from that
// tree: the source tree's config/, <build>/firmware/<board>/ and <build>/web/www. An installed
// executable takes them from the data folder of its own prefix, <prefix>/share/scaratwin, found
// relative to its own location (<prefix>/bin), so a prefix that is moved as a whole keeps
// working; it never looks into a source or build tree. $SCARATWIN_DATA_DIR overrides both (for a
// data folder that was moved on its own). A program that links the installed libraries from
// elsewhere falls back to the data folder of the prefix the libraries were configured for.
//
// Layout of the data folder:
//   config/scara.toml                                robot descriptions
//   firmware/<board>/scaratwin-fw-<board>.{elf,hex}  firmware images (uno, mega)
//   web/index.html ...                               the built page
#pragma once

#include <filesystem>
#include <string>
#include <string_view>

namespace scaratwin {

enum class DataLayout {
  kBuildTree,    // the executable runs from its build tree
  kInstalled,    // <prefix>/share/scaratwin beside the executable's <prefix>/bin
  kEnvironment,  // $SCARATWIN_DATA_DIR
};

struct DataPaths {
  DataLayout layout = DataLayout::kInstalled;
  std::filesystem::path data_dir;      // kInstalled, kEnvironment: the data folder; else empty
  std::filesystem::path config_dir;    // robot descriptions (scara.toml)
  std::filesystem::path firmware_dir;  // <board>/scaratwin-fw-<board>.{elf,hex}
  std::filesystem::path web_root;      // index.html and its assets
  // Empty when the data folder exists; else what is missing and how to fix it (names the path).
  std::string problem;
};

// The paths for the running executable (worked out once, from /proc/self/exe).
const DataPaths& data_paths();

// The firmware image of a board ("uno", "mega"), extension "elf" or "hex".
std::filesystem::path firmware_image(std::string_view board, std::string_view extension);
// The Uno's bootloader (optiboot, built from Debian's source):
// <firmware_dir>/bootloader/optiboot-uno.hex.
std::filesystem::path bootloader_image();

// A message for a data file that cannot be read: names `path`, says what it is (`what`, such as
// "robot description"), and, when the data folder itself is missing, where it was looked for
// and how to point scaratwin at it.
std::string missing_data_message(std::string_view what, const std::filesystem::path& path);

}  // namespace scaratwin
