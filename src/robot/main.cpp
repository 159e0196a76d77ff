// scaratwin-robot: the physical robot without hardware. Runs the real firmware build (the
// Uno ELF) in the simavr AVR emulator and presents its serial port as a pseudo-terminal that
// the hub opens exactly like a USB serial port; models the robot's mechanics from the
// firmware's pins and publishes the truth on a TCP side channel (side_channel.hpp).
// Started directly or as `scaratwin robot`.
//
// SPDX-License-Identifier: GPL-3.0-or-later
// Copyright the scaratwin authors. This program links libsimavr (GPL-3.0) and is
// distributed under the GNU General Public License, version 3 or later; the rest of
// scaratwin is Apache-2.0 and does not link it.
#include <sys/prctl.h>
#include <unistd.h>

#include <cmath>
#include <csignal>
#include <cstdio>
#include <filesystem>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "emulator.hpp"
#include "scaratwin/config/data_paths.hpp"
#include "scaratwin/config/robot_config.hpp"
#include "scaratwin/core/units.hpp"
#include "scaratwin/hub/process.hpp"
#include "scaratwin/kinematics/motor.hpp"

// libsimavr keeps a few allocations (IRQ names, notify hooks) until exit and has no call to
// release them; LeakSanitizer builds (dev and ci presets) would fail every run on them.
extern "C" const char* __lsan_default_suppressions() { return "leak:libsimavr.so\n"; }

namespace {

volatile bool g_stop = false;
void on_signal(int) { g_stop = true; }

// the Uno image of the build tree or of the installed data folder (data_paths.hpp)
std::string default_firmware() { return scaratwin::firmware_image("uno", "elf").string(); }

// the Uno's bootloader: optiboot built from Debian's source (firmware/CMakeLists.txt)
std::string default_bootloader() { return scaratwin::bootloader_image().string(); }

}  // namespace

int main(int argc, char** argv) {
  using namespace scaratwin;
  robot::EmulatorOptions opt;
  std::string firmware = "auto";
  std::string bootloader = default_bootloader();
  bool no_auto_reset = false;
  std::string config_path;
  std::vector<int> start_steps;
  CLI::App app{
      "scaratwin-robot: the physical SCARA emulated: its firmware in simavr, its serial "
      "port on a pty, the true motor positions on a TCP side channel (GPL-3.0-or-later)",
      "scaratwin-robot"};
  app.add_option("--firmware", firmware,
                 "firmware ELF (Uno build) programmed into the flash at power-up, as an ISP "
                 "programmer would; 'none': the flash as --flash holds it (a new board: only "
                 "its bootloader, waiting for 'scaratwin flash'); 'auto': none when the --flash "
                 "file exists, else " +
                     default_firmware())
      ->capture_default_str();
  app.add_option("--bootloader", bootloader,
                 "the bootloader in the boot section, where every reset starts (Intel HEX; "
                 "'none': resets start the firmware)")
      ->capture_default_str();
  app.add_option("--flash", opt.flash_file,
                 "keep the flash in this file, as --eeprom keeps the EEPROM: what 'scaratwin "
                 "flash' wrote through the bootloader survives a restart");
  bool auto_reset = false;
  app.add_flag("--auto-reset", auto_reset,
               "a Uno's auto-reset, the default: opening the port resets the MCU, as the USB "
               "chip does on DTR");
  app.add_flag("--no-auto-reset", no_auto_reset,
               "a board with its auto-reset cut (10 uF between RESET and GND): opening the port "
               "does not reset the MCU")
      ->excludes("--auto-reset");
  app.add_option("--speed", opt.speed, "emulated seconds per wall-clock second; 0 = unpaced")
      ->capture_default_str()
      ->check(CLI::Range(0.0, 1000.0));
  app.add_option("--duration", opt.duration_s, "stop after this many emulated seconds (0 = never)");
  app.add_option("--side-port", opt.side_port, "side-channel TCP port on 127.0.0.1 (0 = any free)")
      ->capture_default_str();
  app.add_option("--scenario", opt.scenario,
                 "file of '<t_ms> <command>' lines (button presses, "
                 "faults) run at those emulated times")
      ->check(CLI::ExistingFile);
  app.add_option("--pty-link", opt.pty_symlink, "also make this symlink to the pty");
  app.add_option("--config", config_path, "robot description (default config/scara.toml)");
  app.add_option("--start-steps", start_steps,
                 "true Z,J2,J3 motor steps at power-up "
                 "(default: the home pose)")
      ->delimiter(',')
      ->expected(3);
  app.add_option("--eeprom", opt.eeprom_file,
                 "keep the EEPROM (the firmware's settings) in this file: loaded at start (an "
                 "absent file is an erased EEPROM) and written whenever the firmware changes it, "
                 "so settings survive a restart as they survive a board's power cycle");
  std::string profile_path;
  app.add_option("--profile", profile_path,
                 "write a CPU profile of the firmware (share of cycles per function, sampled "
                 "every 61 cycles) to this file at exit");
  std::string plant_kind = "as-built";
  app.add_option("--plant", plant_kind,
                 "the physical world behind the pins: as-built (stepper physics, backlash, "
                 "tolerances, physical cubes) or ideal (STEP pulses counted, the robot exactly "
                 "its description)")
      ->capture_default_str()
      ->check(CLI::IsMember({"as-built", "ideal"}));
  double payload_kg = 0.0;
  app.add_option("--payload", payload_kg, "a mass held at the tool, kg (as-built)")
      ->check(CLI::Range(0.0, 2.0));
  long long as_built_seed = -1;
  app.add_option("--as-built-seed", as_built_seed,
                 "seed of the as-built draw (default: [as_built] seed of the description)")
      ->check(CLI::Range(0LL, 2147483647LL));
  int camera_port = 0;
  app.add_option("--camera-port", camera_port,
                 "port of the real camera over the physical table on 127.0.0.1 (as-built; 0 = "
                 "any free port, -1 = no camera)")
      ->capture_default_str()
      ->check(CLI::Range(-1, 65535));
  int ready_fd = -1;
  app.add_option("--ready-fd", ready_fd,
                 "once the firmware runs, write one JSON line on this open descriptor (pty, "
                 "side_port, camera_port, plant, auto_reset) and close it: for the programs "
                 "that start the emulator")
      ->check(CLI::Range(3, 1023));
  int parent_fd = -1;
  app.add_option("--parent-fd", parent_fd,
                 "end (as on SIGTERM) once this descriptor, a pipe from the program that started "
                 "the emulator, reads its end: that program is gone, however it died")
      ->check(CLI::Range(3, 1023));
  bool exit_with_parent = false;
  app.add_flag("--exit-with-parent", exit_with_parent,
               "terminate when the process that started the emulator dies (tests)");
  CLI11_PARSE(app, argc, argv);
  if (exit_with_parent) ::prctl(PR_SET_PDEATHSIG, SIGTERM);
  opt.auto_reset = !no_auto_reset;
  if (bootloader != "none") opt.bootloader = bootloader;
  if (firmware == "auto") {
    std::error_code ec;
    const bool flashed = !opt.flash_file.empty() && std::filesystem::exists(opt.flash_file, ec);
    if (!flashed) opt.firmware = default_firmware();
  } else if (firmware != "none") {
    opt.firmware = firmware;
  }

  auto model = load_robot_config_or_default(config_path);
  if (!model) {
    std::fprintf(stderr, "scaratwin-robot: %s\n", model.error().message.c_str());
    return 2;
  }
  const auto home = joints_to_steps(*model, model->home);
  for (int i = 0; i < 3; ++i) {
    opt.mechanics.start_steps[i] = start_steps.size() == 3 ? start_steps[i] : home[i];
  }
  // the switches close where the description's [endstops] says (J3's on its joint count)
  const auto endstop = endstop_steps(*model);
  opt.mechanics.z_endstop = endstop[0];
  opt.mechanics.j2_endstop = endstop[1];
  opt.mechanics.j3_endstop = endstop[2];
  opt.mechanics.coupling_permille =
      static_cast<std::int32_t>(std::lround(model->motors.j3_per_j2_coupling * 1000.0));
  opt.mechanics.servo_min_us = model->motors.wrist.pulse_min_us;
  opt.mechanics.servo_max_us = model->motors.wrist.pulse_max_us;
  opt.mechanics.servo_min_deg = model->motors.wrist.min_deg;
  opt.mechanics.servo_max_deg = model->motors.wrist.max_deg;

  if (plant_kind == "as-built") {
    robot::EmulatorOptions::PlantSetup ps;
    ps.description = *model;
    AsBuiltProfile profile = model->physical.as_built;
    if (as_built_seed >= 0) profile.seed = static_cast<std::uint64_t>(as_built_seed);
    ps.as_built = draw_as_built(profile);
    ps.options.payload_kg = payload_kg;
    // the power-up pose: where --start-steps put the motors, else home
    std::array<double, 3> s{};
    for (int i = 0; i < 3; ++i) s[i] = opt.mechanics.start_steps[i];
    ps.options.start = motors_to_joints(*model, s, rad_to_deg(model->home[3]));
    ps.options.start_given = true;
    opt.plant = ps;
  } else if (payload_kg > 0.0) {
    std::fprintf(stderr, "scaratwin-robot: --payload needs --plant as-built\n");
    return 2;
  }
  opt.camera_port = camera_port;
  if (!profile_path.empty()) opt.profile_cycles = 61;
  if (std::error_code ec; !opt.bootloader.empty() && bootloader == default_bootloader() &&
                          !std::filesystem::exists(opt.bootloader, ec)) {
    std::fprintf(stderr, "scaratwin-robot: %s (or pass --bootloader FILE or none)\n",
                 scaratwin::missing_data_message("bootloader", opt.bootloader).c_str());
    return 1;
  }
  if (std::error_code ec;
      opt.firmware == default_firmware() && !std::filesystem::exists(opt.firmware, ec)) {
    std::fprintf(stderr, "scaratwin-robot: %s (or pass --firmware PATH)\n",
                 scaratwin::missing_data_message("firmware image", opt.firmware).c_str());
    return 1;
  }
  auto emu = robot::Emulator::create(opt);
  if (!emu) {
    std::fprintf(stderr, "scaratwin-robot: %s\n", emu.error().message.c_str());
    return 1;
  }
  robot::Emulator& e = **emu;
  if (!opt.pty_symlink.empty()) {
    ::unlink(opt.pty_symlink.c_str());
    if (::symlink(e.pty().slave_path().c_str(), opt.pty_symlink.c_str()) != 0) {
      std::fprintf(stderr, "scaratwin-robot: cannot create symlink %s\n", opt.pty_symlink.c_str());
      return 1;
    }
  }
  std::printf("scaratwin-robot: firmware %s on %s at 16 MHz, speed %g\n",
              opt.firmware.empty() ? (opt.flash_file.empty() ? "(none)" : opt.flash_file.c_str())
                                   : opt.firmware.c_str(),
              opt.mcu.c_str(), opt.speed);
  std::printf("bootloader: %s; auto-reset on open: %s\n",
              opt.bootloader.empty() ? "none" : opt.bootloader.c_str(),
              opt.auto_reset ? "yes" : "no");
  if (opt.plant) {
    std::printf("plant: as-built (seed %llu)\n",
                static_cast<unsigned long long>(as_built_seed >= 0
                                                    ? static_cast<unsigned long long>(as_built_seed)
                                                    : model->physical.as_built.seed));
  } else {
    std::printf("plant: ideal\n");
  }
  std::printf("pty: %s\n", e.pty().slave_path().c_str());
  std::printf("side channel: 127.0.0.1:%u\n", static_cast<unsigned>(e.side().port()));
  if (e.camera_port() != 0) {
    std::printf("camera: 127.0.0.1:%u\n", static_cast<unsigned>(e.camera_port()));
  }
  std::fflush(stdout);
  if (ready_fd >= 0) {
    const nlohmann::json ready = {{"program", "scaratwin-robot"},
                                  {"pty", e.pty().slave_path()},
                                  {"side_port", e.side().port()},
                                  {"camera_port", e.camera_port()},
                                  {"plant", opt.plant ? "as-built" : "ideal"},
                                  {"auto_reset", opt.auto_reset}};
    if (Status s = announce_ready(ready_fd, ready.dump()); !s) {
      std::fprintf(stderr, "scaratwin-robot: %s\n", s.error().message.c_str());
      return 1;
    }
  }
  std::signal(SIGINT, on_signal);
  std::signal(SIGTERM, on_signal);
  std::signal(SIGPIPE, SIG_IGN);
  if (parent_fd >= 0) exit_with_parent_fd(parent_fd);
  Status st = e.run(g_stop);
  std::printf("final %s\n", e.truth_line().c_str());  // the truth when the run ended
  if (!opt.pty_symlink.empty()) ::unlink(opt.pty_symlink.c_str());
  if (!profile_path.empty()) {
    if (FILE* f = std::fopen(profile_path.c_str(), "w")) {
      std::fputs(e.profile_table().c_str(), f);
      std::fclose(f);
    } else {
      std::fprintf(stderr, "scaratwin-robot: cannot write the profile to %s\n",
                   profile_path.c_str());
    }
  }
  if (!st) {
    std::fprintf(stderr, "scaratwin-robot: %s\n", st.error().message.c_str());
    return 1;
  }
  return 0;
}
