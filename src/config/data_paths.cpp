#include "scaratwin/config/data_paths.hpp"

#include <cstdlib>
#include <system_error>

#include <fmt/format.h>

// Set by src/CMakeLists.txt for this file alone: the build tree's folders, and the installed
// layout (the data folder relative to the bin folder, and the configured prefix's data folder).
#if !defined(SCARATWIN_BUILD_BIN_DIR) || !defined(SCARATWIN_BUILD_CONFIG_DIR) ||    \
    !defined(SCARATWIN_BUILD_FIRMWARE_DIR) || !defined(SCARATWIN_BUILD_WEB_ROOT) || \
    !defined(SCARATWIN_BIN_TO_DATA) || !defined(SCARATWIN_INSTALL_DATA_DIR)
#error "data_paths.cpp needs the SCARATWIN_BUILD_* and SCARATWIN_*DATA* definitions of CMake"
#endif

namespace scaratwin {
namespace {

namespace fs = std::filesystem;

DataPaths from_data_dir(DataLayout layout, const fs::path& dir) {
  DataPaths p;
  p.layout = layout;
  p.data_dir = dir.lexically_normal();
  p.config_dir = p.data_dir / "config";
  p.firmware_dir = p.data_dir / "firmware";
  p.web_root = p.data_dir / "web";
  return p;
}

DataPaths find_data_paths() {
  std::error_code ec;
  if (const char* env = std::getenv("SCARATWIN_DATA_DIR"); env != nullptr && *env != '\0') {
    DataPaths p = from_data_dir(DataLayout::kEnvironment, fs::absolute(env, ec));
    if (!fs::is_directory(p.data_dir, ec)) {
      p.problem = fmt::format(
          "SCARATWIN_DATA_DIR='{}' is not a folder (set it to scaratwin's data folder, "
          "<prefix>/share/scaratwin, or unset it)",
          env);
    }
    return p;
  }
  const fs::path exe = fs::read_symlink("/proc/self/exe", ec);
  const fs::path exe_dir = ec ? fs::path() : exe.parent_path();
  // /proc/self/exe is resolved, and so is the build's bin folder (by CMake): an installed
  // executable compares the two names and never touches the build tree
  if (!exe_dir.empty() && exe_dir == fs::path(SCARATWIN_BUILD_BIN_DIR)) {
    DataPaths p;
    p.layout = DataLayout::kBuildTree;
    p.config_dir = SCARATWIN_BUILD_CONFIG_DIR;
    p.firmware_dir = SCARATWIN_BUILD_FIRMWARE_DIR;
    p.web_root = SCARATWIN_BUILD_WEB_ROOT;
    return p;
  }
  const fs::path beside = exe_dir.empty() ? fs::path() : exe_dir / SCARATWIN_BIN_TO_DATA;
  if (!beside.empty() && fs::is_directory(beside, ec)) {
    return from_data_dir(DataLayout::kInstalled, beside);
  }
  // a program outside <prefix>/bin that links the installed libraries
  if (fs::is_directory(SCARATWIN_INSTALL_DATA_DIR, ec)) {
    return from_data_dir(DataLayout::kInstalled, SCARATWIN_INSTALL_DATA_DIR);
  }
  DataPaths p = from_data_dir(DataLayout::kInstalled,
                              beside.empty() ? fs::path(SCARATWIN_INSTALL_DATA_DIR) : beside);
  p.problem = fmt::format(
      "scaratwin's data folder '{}' does not exist (it belongs beside '{}'; was it moved or "
      "deleted?): reinstall scaratwin, or set SCARATWIN_DATA_DIR to the folder's new place",
      p.data_dir.string(), exe_dir.string());
  return p;
}

}  // namespace

const DataPaths& data_paths() {
  static const DataPaths paths = find_data_paths();
  return paths;
}

fs::path firmware_image(std::string_view board, std::string_view extension) {
  return data_paths().firmware_dir / std::string(board) /
         fmt::format("scaratwin-fw-{}.{}", board, extension);
}

fs::path bootloader_image() {
  return data_paths().firmware_dir / "bootloader" / "optiboot-uno.hex";
}

std::string missing_data_message(std::string_view what, const fs::path& path) {
  const DataPaths& p = data_paths();
  if (!p.problem.empty())
    return fmt::format("cannot read {} '{}': {}", what, path.string(), p.problem);
  if (p.layout == DataLayout::kBuildTree) {
    return fmt::format(
        "cannot read {} '{}': no such file in the build tree (is the build "
        "complete?)",
        what, path.string());
  }
  return fmt::format(
      "cannot read {} '{}': no such file in scaratwin's data folder '{}' (is the "
      "installation complete?)",
      what, path.string(), p.data_dir.string());
}

}  // namespace scaratwin
