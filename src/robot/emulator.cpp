// SPDX-License-Identifier: GPL-3.0-or-later (scaratwin-robot emulator, see emulator.hpp)
#include "emulator.hpp"

#include "intel_hex.hpp"

#include <poll.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <fstream>
#include <iterator>
#include <sstream>

#include <fmt/format.h>

namespace scaratwin::robot {
namespace {

// Uno pins (board.h of the firmware): STEP PD2..4, DIR PD5..7, endstops PB1..3,
// servos PC0 (gripper) / PC1 (wrist), buttons PC2..5, PB4, PB5.
struct PinRef {
  char port;
  int bit;
};
constexpr std::array<PinRef, 3> kStep{{{'D', 2}, {'D', 3}, {'D', 4}}};
constexpr std::array<PinRef, 3> kDir{{{'D', 5}, {'D', 6}, {'D', 7}}};
constexpr std::array<PinRef, 3> kEndstop{{{'B', 1}, {'B', 2}, {'B', 3}}};
constexpr std::array<PinRef, 2> kServo{{{'C', 0}, {'C', 1}}};
constexpr std::array<PinRef, 6> kButton{
    {{'C', 2}, {'C', 3}, {'C', 4}, {'C', 5}, {'B', 4}, {'B', 5}}};
constexpr std::array<const char*, 6> kButtonNames{"z+", "z-", "j2+", "j2-", "j3+", "j3-"};
constexpr std::array<const char*, 3> kAxisNames{"z", "j2", "j3"};

std::uint64_t clock_us(clockid_t id) {
  timespec ts{};
  clock_gettime(id, &ts);
  return static_cast<std::uint64_t>(ts.tv_sec) * 1000000ULL +
         static_cast<std::uint64_t>(ts.tv_nsec) / 1000ULL;
}

int find_name(const auto& names, const std::string& s) {
  for (std::size_t i = 0; i < names.size(); ++i)
    if (s == names[i]) return static_cast<int>(i);
  return -1;
}

}  // namespace

Result<std::vector<ScenarioStep>> parse_scenario(const std::string& text) {
  std::vector<ScenarioStep> steps;
  std::istringstream in(text);
  std::string line;
  int line_no = 0;
  while (std::getline(in, line)) {
    ++line_no;
    const auto hash = line.find('#');
    if (hash != std::string::npos) line.erase(hash);
    std::istringstream ls(line);
    double t_ms = 0;
    if (!(ls >> t_ms)) {
      if (line.find_first_not_of(" \t\r") == std::string::npos) continue;
      return Error{EmulatorError::kBadScenario, "scenario line " + std::to_string(line_no) + ": '" +
                                                    line + "' does not start with a time in ms"};
    }
    std::string rest;
    std::getline(ls >> std::ws, rest);
    if (!rest.empty() && rest.back() == '\r') rest.pop_back();
    if (rest.empty()) {
      return Error{EmulatorError::kBadScenario,
                   "scenario line " + std::to_string(line_no) + ": no command after the time"};
    }
    steps.push_back({t_ms / 1000.0, rest});
  }
  std::stable_sort(steps.begin(), steps.end(),
                   [](const ScenarioStep& a, const ScenarioStep& b) { return a.t_s < b.t_s; });
  return steps;
}

namespace {
constexpr double kBootS = 0.05;  // emulated time by which the firmware has set up its pins

// Writes a non-volatile memory's bytes `now` to `path` when they differ from `saved` (which
// then becomes them): a new file renamed over the old one, so a run killed in the middle
// leaves one or the other. Nothing without a path.
void keep_memory(const std::string& path, std::span<const std::uint8_t> now,
                 std::vector<std::uint8_t>& saved, const char* what) {
  if (path.empty()) return;
  if (std::equal(now.begin(), now.end(), saved.begin(), saved.end())) return;
  const std::string tmp = path + ".new";
  {
    std::ofstream f(tmp, std::ios::binary | std::ios::trunc);
    f.write(reinterpret_cast<const char*>(now.data()), static_cast<std::streamsize>(now.size()));
    if (!f) {
      std::fprintf(stderr, "scaratwin-robot: cannot write the %s to %s\n", what, tmp.c_str());
      return;
    }
  }
  if (std::rename(tmp.c_str(), path.c_str()) != 0) {
    std::fprintf(stderr, "scaratwin-robot: cannot write the %s to %s\n", what, path.c_str());
    return;
  }
  saved.assign(now.begin(), now.end());
}
}  // namespace

Emulator::Emulator(const EmulatorOptions& o, std::unique_ptr<AvrMachine> m, PtyLink pty,
                   SideChannel side)
    : options_(o),
      avr_(std::move(m)),
      pty_(std::move(pty)),
      side_(std::move(side)),
      mech_(o.mechanics) {}

Result<std::unique_ptr<Emulator>> Emulator::create(const EmulatorOptions& options) {
  std::vector<ScenarioStep> scenario;
  if (!options.scenario.empty()) {
    std::ifstream f(options.scenario);
    if (!f)
      return Error{EmulatorError::kBadScenario,
                   "cannot read scenario file '" + options.scenario + "'"};
    std::stringstream ss;
    ss << f.rdbuf();
    auto parsed = parse_scenario(ss.str());
    if (!parsed) return parsed.error();
    scenario = std::move(parsed).value();
  }
  auto machine = AvrMachine::load(options.firmware, options.mcu, 16000000);
  if (!machine) return machine.error();
  auto pty = PtyLink::open(options.auto_reset);
  if (!pty) return pty.error();
  auto side = SideChannel::listen(options.side_port);
  if (!side) return side.error();
  std::unique_ptr<Emulator> e(new Emulator(options, std::move(machine).value(),
                                           std::move(pty).value(), std::move(side).value()));
  e->scenario_ = std::move(scenario);
  if (options.plant) {
    auto plant = plant::Plant::create(options.plant->description, options.plant->as_built,
                                      options.plant->options);
    if (!plant) return Error{EmulatorError::kSetup, "the physical world: " + plant.error().message};
    e->plant_ = std::move(plant).value();
    if (options.camera_port >= 0) {
      auto cam = SideChannel::listen(static_cast<std::uint16_t>(options.camera_port));
      if (!cam) return Error{EmulatorError::kSetup, "the camera's port: " + cam.error().message};
      cam->set_blocking_replies(true);
      e->camera_port_.emplace(std::move(cam).value());
    }
  }
  if (Status st = e->load_flash(); !st) return st.error();
  e->host_present_ = !options.auto_reset;
  e->wire_pins();
  if (Status st = e->load_eeprom(); !st) return st.error();
  for (const auto& s : e->scenario_) {
    // validate the commands now rather than failing in the middle of a run
    std::istringstream ls(s.command);
    std::string verb;
    ls >> verb;
    static const char* kVerbs[] = {"press",   "release", "cut",    "lose",  "corrupt",
                                   "query",   "rate",    "mark",   "place", "clear",
                                   "payload", "pattern", "endstop"};
    if (std::find_if(std::begin(kVerbs), std::end(kVerbs),
                     [&](const char* v) { return verb == v; }) == std::end(kVerbs)) {
      return Error{
          EmulatorError::kBadScenario,
          "scenario command '" + s.command +
              "' is unknown: use press, release, cut, lose, corrupt, endstop, place, clear, "
              "payload or pattern"};
    }
  }
  return e;
}

void Emulator::wire_pins() {
  for (int a = 0; a < kAxes; ++a) {
    avr_->watch_pin(kDir[a].port, kDir[a].bit, [this, a](bool high) { mech_.on_dir(a, high); });
    avr_->watch_pin(kStep[a].port, kStep[a].bit, [this, a](bool high) {
      const std::int32_t before = mech_.steps()[a];
      mech_.on_step(a, high, avr_->sim_us());
      // a pulse the belt fault swallowed (lose) does not reach the motor either
      const std::int32_t moved = mech_.steps()[a] - before;
      if (plant_ && moved != 0) plant_->step_pulse(a, moved > 0, avr_->sim_seconds());
      update_endstops();
    });
  }
  for (int s = 0; s < 2; ++s) {
    avr_->watch_pin(kServo[s].port, kServo[s].bit, [this, s](bool high) {
      mech_.on_servo(s, high, avr_->cycle(), avr_->frequency() / 1e6);
      if (plant_ && !high) plant_->servo_pulse(s, mech_.servo_pulse_us(s));
    });
  }
  avr_->on_uart_output([this](std::uint8_t b) { to_host(b); });
  if (options_.profile_cycles > 0) avr_->start_profile(options_.profile_cycles);
  // inputs idle high (pull-ups): open switches, released buttons
  for (int b = 0; b < 6; ++b) avr_->drive_pin(kButton[b].port, kButton[b].bit, true);
  update_endstops();
}

Status Emulator::load_eeprom() {
  const auto now = avr_->eeprom();
  eeprom_saved_.assign(now.begin(), now.end());
  const std::string& path = options_.eeprom_file;
  if (path.empty()) return Ok{};
  std::ifstream f(path, std::ios::binary);
  if (!f) return Ok{};  // a new board: the EEPROM erased (simavr starts it at 0xff)
  std::vector<std::uint8_t> bytes((std::istreambuf_iterator<char>(f)),
                                  std::istreambuf_iterator<char>());
  if (!avr_->set_eeprom(bytes)) {
    return Error{EmulatorError::kBadOption,
                 fmt::format("--eeprom {}: {} bytes, but the {}'s EEPROM holds {} (give a file "
                             "an earlier run wrote, or a new path)",
                             path, bytes.size(), options_.mcu, eeprom_saved_.size())};
  }
  eeprom_saved_ = std::move(bytes);
  return Ok{};
}

Status Emulator::load_flash() {
  const std::string& path = options_.flash_file;
  const std::size_t size = avr_->flash().size();
  bool programmed = !options_.firmware.empty();
  if (!path.empty() && options_.firmware.empty()) {
    std::ifstream f(path, std::ios::binary);
    if (f) {
      std::vector<std::uint8_t> bytes((std::istreambuf_iterator<char>(f)),
                                      std::istreambuf_iterator<char>());
      if (!avr_->set_flash(bytes)) {
        return Error{EmulatorError::kBadOption,
                     fmt::format("--flash {}: {} bytes, but the {}'s flash holds {} (give a file "
                                 "an earlier run wrote, or a new path)",
                                 path, bytes.size(), options_.mcu, size)};
      }
    } else {
      programmed = true;  // a new board: its flash as it came (the bootloader, if any)
    }
  }
  if (!options_.bootloader.empty()) {
    auto chunks = read_intel_hex(options_.bootloader);
    if (!chunks) return Error{EmulatorError::kBadOption, "--bootloader " + chunks.error().message};
    if (chunks->empty()) {
      return Error{EmulatorError::kBadOption, "--bootloader " + options_.bootloader + ": no data"};
    }
    std::uint32_t start = UINT32_MAX;
    for (const HexChunk& c : *chunks) start = std::min(start, c.address);
    // a boot section is at most the upper half of the flash (BOOTSZ)
    if (start < size / 2) {
      return Error{EmulatorError::kBadOption,
                   fmt::format("--bootloader {}: it starts at 0x{:04x}, not in a boot section "
                               "(0x{:04x} and up on the {})",
                               options_.bootloader, start, size / 2, options_.mcu)};
    }
    for (const HexChunk& c : *chunks) {
      if (c.address + c.bytes.size() > size) {
        return Error{EmulatorError::kBadOption,
                     fmt::format("--bootloader {}: bytes at 0x{:04x} beyond the {}'s {} bytes",
                                 options_.bootloader, c.address, options_.mcu, size)};
      }
      // a flash file holds its bootloader already: the programmer writes it on a new chip
      if (programmed) avr_->write_flash(c.address, c.bytes);
    }
    avr_->set_reset_vector(start);
  }
  const auto now = avr_->flash();
  if (!path.empty() && programmed) {
    flash_saved_.clear();  // write it now: the file is the board's flash from here on
    save_flash_if_changed();
  }
  flash_saved_.assign(now.begin(), now.end());
  return Ok{};
}

void Emulator::save_flash_if_changed() {
  keep_memory(options_.flash_file, avr_->flash(), flash_saved_, "flash");
}

void Emulator::watch_host(double now_s) {
  // DTR asserted: the USB chip's capacitor pulls RESET low for a moment
  for (int n = pty_.take_first_opens(); n > 0; --n) reset_board(now_s);
  host_present_ = pty_.host_open();
}

void Emulator::reset_board(double now_s) {
  avr_->reset_external();
  boot_until_s_ = now_s + kBootS;  // the switches driven again while it boots
  drop_backlog_ = true;
}

void Emulator::save_eeprom_if_changed() {
  keep_memory(options_.eeprom_file, avr_->eeprom(), eeprom_saved_, "EEPROM");
}

void Emulator::update_endstops() {
  std::uint8_t es = plant_ ? plant_->endstops() : mech_.endstops();
  es = static_cast<std::uint8_t>((es & ~endstop_forced_mask_) | endstop_forced_closed_);
  if (es == endstops_driven_) return;
  for (int a = 0; a < kAxes; ++a) {
    const bool closed = (es >> a) & 1;
    if (endstops_driven_ == 0xff || closed != static_cast<bool>((endstops_driven_ >> a) & 1)) {
      avr_->drive_pin(kEndstop[a].port, kEndstop[a].bit, !closed);  // closed pulls low
    }
  }
  endstops_driven_ = es;
}

void Emulator::set_button(int button, bool pressed) {
  if (pressed)
    buttons_ = static_cast<std::uint8_t>(buttons_ | (1u << button));
  else
    buttons_ = static_cast<std::uint8_t>(buttons_ & ~(1u << button));
  avr_->drive_pin(kButton[button].port, kButton[button].bit, !pressed);
}

bool Emulator::link_cut() const {
  return avr_->sim_seconds() < cut_until_s_ || splice_ == Splice::kCutting;
}

void Emulator::from_host(const std::vector<std::uint8_t>& bytes) {
  for (std::uint8_t b : bytes) {
    if (link_cut()) continue;
    if (corrupt_rx_ > 0) {
      --corrupt_rx_;
      b ^= 0x55;
    }
    last_rx_sim_us_ = avr_->sim_us();
    avr_->uart_send(b);
  }
}

void Emulator::to_host(std::uint8_t b) {
  // a splice cut starts and ends right after a state report's t_us field (its third '='):
  // the report cut in two and the later one it resumes in make one line that decodes, with
  // the first one's seq and clock and the later one's positions (the wire has no checksum)
  const bool splice_point = tx_state_report_ && tx_delims_ == 3 && tx_prev_ == '=';
  if (splice_ == Splice::kArmed && splice_point) {
    splice_ = Splice::kCutting;
    splice_until_s_ = avr_->sim_seconds() + splice_ms_ / 1000.0;
  } else if (splice_ == Splice::kCutting && splice_point &&
             avr_->sim_seconds() >= splice_until_s_) {
    splice_ = Splice::kNone;
  }
  if (b == '\n') {
    tx_len_ = tx_delims_ = 0;
    tx_state_report_ = false;
  } else {
    if (tx_len_ == 0) tx_first_ = b;
    if (tx_len_ == 1) tx_state_report_ = tx_first_ == 'S' && b == 'T';
    ++tx_len_;
    if (b == '=') ++tx_delims_;
  }
  tx_prev_ = b;
  if (link_cut()) return;
  if (corrupt_tx_ > 0) {
    --corrupt_tx_;
    b ^= 0x55;
  }
  pty_.put(b);
}

std::string Emulator::truth_line() const {
  char buf[512];
  const auto& s = mech_.steps();
  std::snprintf(buf, sizeof buf,
                "TR wall_us=%llu mono_us=%llu sim_us=%llu z=%d j2=%d j3=%d wrist_cdeg=%d "
                "grip_cdeg=%d endstops=%u buttons=%u steps_z=%llu steps_j2=%llu steps_j3=%llu "
                "last_step_sim_us=%llu last_rx_sim_us=%llu span_z=%llu:%llu span_j2=%llu:%llu "
                "span_j3=%llu:%llu resets=%u wdt_resets=%u boot=%d board_us=%llu",
                static_cast<unsigned long long>(clock_us(CLOCK_REALTIME)),
                static_cast<unsigned long long>(clock_us(CLOCK_MONOTONIC)),
                static_cast<unsigned long long>(avr_->sim_us()), s[0], s[1], s[2],
                mech_.servo_cdeg(1), mech_.servo_cdeg(0), mech_.endstops(), buttons_,
                static_cast<unsigned long long>(mech_.step_count(0)),
                static_cast<unsigned long long>(mech_.step_count(1)),
                static_cast<unsigned long long>(mech_.step_count(2)),
                static_cast<unsigned long long>(mech_.last_step_sim_us()),
                static_cast<unsigned long long>(last_rx_sim_us_),
                static_cast<unsigned long long>(mech_.first_step_us(0)),
                static_cast<unsigned long long>(mech_.last_step_us(0)),
                static_cast<unsigned long long>(mech_.first_step_us(1)),
                static_cast<unsigned long long>(mech_.last_step_us(1)),
                static_cast<unsigned long long>(mech_.first_step_us(2)),
                static_cast<unsigned long long>(mech_.last_step_us(2)), avr_->external_resets(),
                avr_->resets() - avr_->external_resets(), avr_->in_boot_section() ? 1 : 0,
                static_cast<unsigned long long>(avr_->us_since_reset()));
  std::string line = buf;
  if (!plant_) return line + " plant=ideal";
  // the robot as built: the true motor positions are the rotors', and the truth adds the
  // true joints, the true tool and the steps the motors lost
  const auto rotor = plant_->rotor_microsteps();
  const auto lost = plant_->lost_microsteps();
  const JointVector q = plant_->joints();
  const ToolPose tool = plant_->tool_pose();
  for (int a = 0; a < kAxes; ++a) {
    const std::string key = std::string(" ") + kAxisNames[a] + "=";
    const std::size_t at = line.find(key);
    const std::size_t end = line.find(' ', at + 1);
    line.replace(at, end - at, fmt::format("{}{}", key, std::llround(rotor[a])));
  }
  line += fmt::format(
      " plant=as-built d1_m={:.7f} q2_rad={:.7f} q3_rad={:.7f} q4_rad={:.7f} tool_x_m={:.7f} "
      "tool_y_m={:.7f} tool_z_m={:.7f} tool_yaw_rad={:.7f} lost_z={} lost_j2={} lost_j3={} "
      "held={}",
      q[0], q[1], q[2], q[3], tool.x_m, tool.y_m, tool.z_m, tool.yaw_rad, lost[0], lost[1], lost[2],
      plant_->held_cube());
  return line;
}

std::string Emulator::camera_command(const std::string& line) {
  std::istringstream in(line);
  std::string verb;
  int w = 0, h = 0;
  in >> verb >> w >> h;
  if (verb != "grab") return "ERR unknown command '" + verb + "': use grab <width> <height>";
  const CameraModel& cam = plant_->built().scene.camera;
  const int max_w = plant::kWebcamScale * cam.width_px, max_h = plant::kWebcamScale * cam.height_px;
  if (w < 16 || h < 16 || w > max_w || h > max_h) {
    return fmt::format("ERR grab needs a size from 16x16 to {}x{}", max_w, max_h);
  }
  if (!camera_) {
    // the lens of this robot's webcam: its own seeded spread around a cheap lens
    plant::LensModel lens;
    lens.seed = options_.plant->description.physical.as_built.seed;
    auto c = plant::PlantCamera::create(*plant_, lens);
    if (!c) return "ERR the camera cannot render: " + c.error().message;
    camera_ = std::move(c).value();
  }
  auto img = camera_->grab(*plant_, w, h);
  if (!img) return "ERR the camera cannot render: " + img.error().message;
  // stamped on the board's clock (the firmware's micros(), which starts over at a reset)
  std::string out = fmt::format("FRAME {} {} {} {} {}\n", camera_->frames(), avr_->us_since_reset(),
                                img->width_px, img->height_px, img->rgb.size());
  out.append(reinterpret_cast<const char*>(img->rgb.data()), img->rgb.size());
  return out;
}

std::string Emulator::cubes_line() const {
  if (!plant_) return "CUBES 0";
  const auto cubes = plant_->cubes();
  std::string out = fmt::format("CUBES {}", cubes.size());
  for (const auto& c : cubes) {
    out += fmt::format(" {}:{}:{:.6f}:{:.6f}:{:.6f}", c.id, color_name(c.color), c.pos_m[0],
                       c.pos_m[1], c.pos_m[2]);
  }
  return out;
}

std::string Emulator::command(const std::string& line, int client) {
  std::istringstream in(line);
  std::string verb;
  in >> verb;
  const double now_s = avr_->sim_seconds();
  if (verb == "query") return truth_line();
  if (verb == "cubes") return cubes_line();
  if (verb == "payload") {
    if (!plant_) return "ERR the ideal robot has no physical world: start with --plant as-built";
    double kg = -1.0;
    if (!(in >> kg)) return "ERR payload needs a mass in kg (0..2)";
    if (Status st = plant_->set_payload(kg); !st) return "ERR " + st.error().message;
    return "OK " + line;
  }
  if (verb == "pattern") {
    if (!plant_) return "ERR the ideal robot has no physical world: start with --plant as-built";
    std::string state;
    in >> state;
    if (state != "on" && state != "off") {
      return "ERR pattern needs on (lay the printed pattern on the table) or off";
    }
    if (Status st = plant_->set_pattern(state == "on"); !st) return "ERR " + st.error().message;
    return "OK pattern " + state;
  }
  if (verb == "place" || verb == "clear") {
    if (!plant_) {
      return "ERR the ideal robot has no physical world: start the emulator with --plant "
             "as-built";
    }
    if (verb == "clear") {
      plant_->clear_cubes();
      return "OK clear";
    }
    std::string colour;
    double x = NAN, y = NAN, yaw_deg = 0.0;
    in >> colour >> x >> y;
    if (!(in >> yaw_deg)) yaw_deg = 0.0;
    auto c = parse_color(colour);
    if (!c) return "ERR place needs a colour (red, green, blue), x and y in m, yaw in deg";
    if (!std::isfinite(x) || !std::isfinite(y)) return "ERR place needs x and y in m";
    auto placed = plant_->place_cube(*c, x, y, yaw_deg * 3.14159265358979323846 / 180.0);
    if (!placed) return "ERR " + placed.error().message;
    return fmt::format("OK place {} {} {:.6f} {:.6f}", placed->id, colour, placed->pos_m[0],
                       placed->pos_m[1]);
  }
  if (verb == "mark") {
    mech_.mark();
    return "OK mark";
  }
  if (verb == "reset") {
    reset_board(now_s);  // the board's reset button
    return "OK reset";
  }
  if (verb == "rate") {
    double hz = -1;
    if (!(in >> hz) || hz < 0 || hz > 10000) return "ERR rate needs 0..10000 Hz";
    side_.set_rate(client, hz);
    return "OK rate " + std::to_string(hz);
  }
  if (verb == "press" || verb == "release") {
    std::string name;
    in >> name;
    const int b = find_name(kButtonNames, name);
    if (b < 0) return "ERR unknown button '" + name + "': use z+ z- j2+ j2- j3+ j3-";
    double ms = 0;
    const bool timed = verb == "press" && static_cast<bool>(in >> ms);
    if (timed && ms <= 0) return "ERR press duration must be > 0 ms";
    set_button(b, verb == "press");
    release_at_s_[b] = timed ? now_s + ms / 1000.0 : 0.0;
    return "OK " + line;
  }
  if (verb == "cut") {
    double ms = 0;
    std::string how;
    if (!(in >> ms) || ms <= 0 || ((in >> how) && how != "splice")) {
      return "ERR cut needs a duration > 0 ms, then splice or nothing";
    }
    if (how == "splice") {
      splice_ = Splice::kArmed;
      splice_ms_ = ms;
    } else {
      cut_until_s_ = now_s + ms / 1000.0;
    }
    return "OK " + line;
  }
  if (verb == "lose") {
    std::string axis;
    long n = 0;
    in >> axis >> n;
    const int a = find_name(kAxisNames, axis);
    if (a < 0 || n <= 0) return "ERR lose needs an axis (z, j2, j3) and a step count > 0";
    mech_.lose_steps(a, static_cast<std::int32_t>(n));
    return "OK " + line;
  }
  if (verb == "endstop") {
    // a broken switch or wire: it reads open (or closed) whatever its axis does
    std::string axis, state;
    in >> axis >> state;
    const int a = find_name(kAxisNames, axis);
    if (a < 0 || (state != "open" && state != "closed" && state != "ok")) {
      return "ERR endstop needs an axis (z, j2, j3) and open, closed or ok";
    }
    const auto bit = static_cast<std::uint8_t>(1u << a);
    endstop_forced_mask_ = static_cast<std::uint8_t>(state == "ok" ? endstop_forced_mask_ & ~bit
                                                                   : endstop_forced_mask_ | bit);
    endstop_forced_closed_ = static_cast<std::uint8_t>(
        state == "closed" ? endstop_forced_closed_ | bit : endstop_forced_closed_ & ~bit);
    update_endstops();
    return "OK " + line;
  }
  if (verb == "corrupt") {
    long n = 0;
    std::string dir = "rx";
    in >> n >> dir;
    if (n <= 0 || (dir != "rx" && dir != "tx")) {
      return "ERR corrupt needs a byte count > 0 and rx (to the firmware) or tx";
    }
    (dir == "rx" ? corrupt_rx_ : corrupt_tx_) += static_cast<std::uint32_t>(n);
    return "OK " + line;
  }
  return "ERR unknown command '" + verb +
         "': use query, rate, mark, reset, press, release, cut, lose, corrupt, endstop, cubes, "
         "place, clear, payload, pattern";
}

namespace {
constexpr double kIdleWaitS = 0.002;  // longest wait for a sleeping firmware's next event
}  // namespace

Status Emulator::run(const volatile bool& stop) {
  const std::uint64_t chunk = avr_->frequency() / 5000;  // 200 us of emulated time
  // wall-clock time of emulated time 0 (moves on when a reset drops a backlog, below)
  std::uint64_t wall0 = clock_us(CLOCK_MONOTONIC);
  const double speed = options_.speed;
  // where the last wait ended: a sleeping firmware skips there (nothing happens before)
  std::uint64_t idle_to = 0;
  while (!stop) {
    if (!avr_->run_until((idle_to > avr_->cycle() ? idle_to : avr_->cycle()) + chunk)) {
      return Error{EmulatorError::kFirmware, "the firmware stopped or crashed at t = " +
                                                 std::to_string(avr_->sim_seconds()) + " s"};
    }
    avr_->restart_blank_loop();  // a new board, waiting for its firmware
    const double now_s = avr_->sim_seconds();
    if (drop_backlog_ && speed > 0) {
      // a reset starts the MCU over in real time: an emulation behind the wall clock (a busy
      // host) does not rush through the bootloader's wait to catch up, which a host opening
      // the port would then find already over
      drop_backlog_ = false;
      const std::uint64_t now_us = clock_us(CLOCK_MONOTONIC);
      const std::uint64_t at_us = wall0 + static_cast<std::uint64_t>(now_s / speed * 1e6);
      if (now_us > at_us) wall0 += now_us - at_us;
    }
    save_eeprom_if_changed();  // before the firmware's reply to a CF can leave (pty_.flush)
    if (avr_->in_boot_section()) {
      boot_ran_ = true;
      boot_until_s_ = now_s + kBootS;  // the firmware starts once the bootloader leaves
    }
    if (boot_ran_ && now_s - flash_checked_s_ >= 0.05) {
      save_flash_if_changed();
      boot_ran_ = avr_->in_boot_section();
      flash_checked_s_ = now_s;
    }
    if (plant_) {
      // the physical world catches up with the firmware's emulated time
      if (Status st = plant_->advance_to(now_s); !st) return st.error();
      update_endstops();
    }
    if (options_.duration_s > 0 && now_s >= options_.duration_s) break;
    if (now_s < boot_until_s_) {
      // the firmware's pin set-up (pull-ups) overrides a level driven before it: a switch
      // closed at power-up (or reset) holds its line low, so drive the switches again until
      // the firmware booted
      endstops_driven_ = 0xff;
      update_endstops();
    }
    while (scenario_next_ < scenario_.size() && scenario_[scenario_next_].t_s <= now_s) {
      const std::string reply = command(scenario_[scenario_next_].command, -1);
      if (reply.rfind("ERR", 0) == 0) std::fprintf(stderr, "scenario: %s\n", reply.c_str());
      ++scenario_next_;
    }
    for (int b = 0; b < 6; ++b) {
      if (release_at_s_[b] > 0 && now_s >= release_at_s_[b]) {
        set_button(b, false);
        release_at_s_[b] = 0;
      }
    }
    // no host has the port open: what the firmware sends is lost, as the USB chip's is
    if (host_present_) {
      pty_.flush();
    } else {
      pty_.discard();
    }
    // wait for the wall clock (paced), handling input as it arrives; unpaced: just look.
    // A sleeping firmware does nothing until its next timer event: wait for that (or for the
    // next scenario step or button release) rather than for every chunk's end, then skip to
    // it; a host byte that comes first ends the wait where the wall clock is.
    std::uint64_t due_us = 0;
    std::uint64_t sync_us = 0;
    double until_s = now_s;
    if (speed > 0) {
      if (now_s >= kBootS) {
        until_s = static_cast<double>(avr_->wake_cycle()) / avr_->frequency();
        if (until_s > now_s + kIdleWaitS) until_s = now_s + kIdleWaitS;
        if (scenario_next_ < scenario_.size() && scenario_[scenario_next_].t_s < until_s) {
          until_s = scenario_[scenario_next_].t_s;
        }
        for (const double r : release_at_s_) {
          if (r > 0 && r < until_s) until_s = r;
        }
        if (until_s < now_s) until_s = now_s;
      }
      sync_us = wall0 + static_cast<std::uint64_t>(now_s / speed * 1e6);
      due_us = wall0 + static_cast<std::uint64_t>(until_s / speed * 1e6);
    }
    const auto cycle_at = [&](std::uint64_t wall_us) {
      const double s = static_cast<double>(wall_us - wall0) * 1e-6 * speed;
      return static_cast<std::uint64_t>((s < until_s ? s : until_s) * avr_->frequency());
    };
    idle_to = 0;
    bool host_byte = false;
    do {
      const std::uint64_t now_us = clock_us(CLOCK_MONOTONIC);
      const long wait_us = due_us > now_us ? static_cast<long>(due_us - now_us) : 0;
      std::vector<pollfd> fds;
      fds.push_back({pty_.master_fd(), POLLIN, 0});
      fds.push_back({pty_.host_events_fd(), POLLIN, 0});  // -1 (ignored) without auto-reset
      fds.push_back({side_.listen_fd(), POLLIN, 0});
      for (int fd : side_.client_fds()) fds.push_back({fd, POLLIN, 0});
      const std::size_t camera_from = fds.size();
      if (camera_port_) {
        fds.push_back({camera_port_->listen_fd(), POLLIN, 0});
        for (int fd : camera_port_->client_fds()) fds.push_back({fd, POLLIN, 0});
      }
      timespec ts{wait_us / 1000000, (wait_us % 1000000) * 1000};
      ppoll(fds.data(), fds.size(), &ts, nullptr);
      if (fds[1].revents & POLLIN) watch_host(avr_->sim_seconds());
      if (fds[0].revents & POLLIN) {
        // the sleeping firmware gets the byte when the wall clock got it (a skip: nothing
        // happens before until_s)
        const std::uint64_t got_us = clock_us(CLOCK_MONOTONIC);
        if (until_s > now_s && got_us > sync_us) avr_->run_until(cycle_at(got_us));
        from_host(pty_.read_available());
        host_byte = true;
      }
      // the side channel only when a client connects, sends or leaves (a system call per
      // client less on each pass)
      bool side_ready = false;
      for (std::size_t i = 2; i < camera_from; ++i) side_ready = side_ready || fds[i].revents != 0;
      if (side_ready) side_.poll([this](const std::string& l, int c) { return command(l, c); });
      bool camera_ready = false;
      for (std::size_t i = camera_from; i < fds.size(); ++i) {
        camera_ready = camera_ready || fds[i].revents != 0;
      }
      if (camera_ready) {
        camera_port_->poll([this](const std::string& l, int) { return camera_command(l); });
      }
      side_.publish(clock_us(CLOCK_MONOTONIC), [this] { return truth_line(); });
    } while (!stop && clock_us(CLOCK_MONOTONIC) < due_us &&
             !(host_byte && clock_us(CLOCK_MONOTONIC) >= sync_us));
    if (!host_byte && speed > 0) idle_to = cycle_at(clock_us(CLOCK_MONOTONIC));
  }
  save_eeprom_if_changed();
  save_flash_if_changed();
  if (host_present_) pty_.flush();
  return Ok{};
}

}  // namespace scaratwin::robot
