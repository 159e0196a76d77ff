// SPDX-License-Identifier: GPL-3.0-or-later (scaratwin-robot emulator, see avr_machine.hpp)
#include "avr_machine.hpp"

#include <cxxabi.h>

#include <algorithm>
#include <cstdarg>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <map>
#include <mutex>

extern "C" {
#include <simavr/avr_eeprom.h>
#include <simavr/avr_extint.h>
#include <simavr/avr_ioport.h>
#include <simavr/avr_uart.h>
#include <simavr/sim_avr.h>
#include <simavr/sim_cycle_timers.h>
#include <simavr/sim_elf.h>
#include <simavr/sim_io.h>
#include <simavr/sim_irq.h>
}

namespace scaratwin::robot {
namespace {

// simavr's messages go to stderr (stdout carries the pty path); only errors are shown
void log_to_stderr(avr_t*, const int level, const char* format, va_list ap) {
  if (level <= LOG_ERROR) std::vfprintf(stderr, format, ap);
}

// simavr calls this while the firmware sleeps; the run loop paces the emulation itself
void no_sleep(avr_t*, avr_cycle_count_t) {}

avr_cycle_count_t profile_hook(avr_t* avr, avr_cycle_count_t when, void* param);

// simavr's reset hook has no user pointer: the machine of each core
std::mutex g_machines_mu;
std::map<avr_t*, AvrMachine*> g_machines;

void fix_simavr_defaults(avr_t* avr) {
  for (int i = 0; i < 2; ++i) avr_extint_set_strict_lvl_trig(avr, static_cast<uint8_t>(i), 0);
  std::uint32_t flags = 0;
  avr_ioctl(avr, AVR_IOCTL_UART_GET_FLAGS('0'), &flags);
  flags &= ~(AVR_UART_FLAG_STDIO | AVR_UART_FLAG_POLL_SLEEP);
  avr_ioctl(avr, AVR_IOCTL_UART_SET_FLAGS('0'), &flags);
}

}  // namespace

Result<std::unique_ptr<AvrMachine>> AvrMachine::load(const std::string& elf_path,
                                                     const std::string& mcu,
                                                     std::uint32_t frequency_hz) {
  avr_global_logger_set(log_to_stderr);
  std::unique_ptr<AvrMachine> m(new AvrMachine());
  m->fw_ = static_cast<elf_firmware_t*>(std::calloc(1, sizeof(elf_firmware_t)));
  elf_firmware_t& fw = *m->fw_;
  if (!elf_path.empty() && elf_read_firmware(elf_path.c_str(), &fw) != 0) {
    return Error{EmulatorError::kFirmware,
                 "cannot read firmware ELF '" + elf_path +
                     "': build it (target firmware_uno) or pass --firmware PATH"};
  }
  avr_t* avr = avr_make_mcu_by_name(mcu.c_str());
  if (avr == nullptr)
    return Error{EmulatorError::kFirmware, "simavr does not know the MCU '" + mcu + "'"};
  avr_init(avr);
  std::snprintf(fw.mmcu, sizeof fw.mmcu, "%s", mcu.c_str());
  fw.frequency = frequency_hz;
  avr->frequency = frequency_hz;
  if (!elf_path.empty()) avr_load_firmware(avr, &fw);
  // code may run anywhere in the flash: a bootloader at its end, a firmware it writes
  avr->codeend = avr->flashend;
  avr->sleep = no_sleep;
  fix_simavr_defaults(avr);

  m->avr_ = avr;
  m->frequency_ = frequency_hz;
  m->core_reset_ = avr->reset;
  avr->reset = &AvrMachine::reset_hook;
  {
    std::lock_guard<std::mutex> lock(g_machines_mu);
    g_machines[avr] = m.get();
  }
  m->uart_in_ = avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_INPUT);
  avr_irq_register_notify(avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_OUTPUT),
                          &AvrMachine::uart_out_hook, m.get());
  avr_irq_register_notify(avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_OUT_XON),
                          &AvrMachine::xon_hook, m.get());
  avr_irq_register_notify(avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_OUT_XOFF),
                          &AvrMachine::xoff_hook, m.get());
  return m;
}

AvrMachine::~AvrMachine() {
  if (avr_ != nullptr) {
    {
      std::lock_guard<std::mutex> lock(g_machines_mu);
      g_machines.erase(avr_);
    }
    avr_terminate(avr_);
    std::free(avr_);
  }
  if (fw_ != nullptr) {
    std::free(fw_->flash);
    std::free(fw_->eeprom);
    std::free(fw_->fuse);
    std::free(fw_->lockbits);
    for (std::uint32_t i = 0; i < fw_->symbolcount; ++i) std::free(fw_->symbol[i]);
    std::free(fw_->symbol);
    std::free(fw_);
  }
}

void AvrMachine::pin_hook(avr_irq_t*, std::uint32_t value, void* param) {
  (*static_cast<PinCallback*>(param))(value != 0);
}

void AvrMachine::uart_out_hook(avr_irq_t*, std::uint32_t value, void* param) {
  auto* self = static_cast<AvrMachine*>(param);
  if (self->uart_out_) self->uart_out_(static_cast<std::uint8_t>(value));
}

void AvrMachine::xon_hook(avr_irq_t*, std::uint32_t, void* param) {
  auto* self = static_cast<AvrMachine*>(param);
  self->xoff_ = false;
  self->feed_uart();
}

void AvrMachine::xoff_hook(avr_irq_t*, std::uint32_t, void* param) {
  static_cast<AvrMachine*>(param)->xoff_ = true;
}

void AvrMachine::watch_pin(char port, int bit, PinCallback cb) {
  pin_callbacks_.push_back(std::make_unique<PinCallback>(std::move(cb)));
  avr_irq_t* irq = avr_io_getirq(avr_, AVR_IOCTL_IOPORT_GETIRQ(port), bit);
  avr_irq_register_notify(irq, &AvrMachine::pin_hook, pin_callbacks_.back().get());
}

void AvrMachine::drive_pin(char port, int bit, bool level) {
  Driven& d = driven_[port - 'B'];
  const auto m = static_cast<std::uint8_t>(1u << bit);
  d.mask = static_cast<std::uint8_t>(d.mask | m);
  d.level = static_cast<std::uint8_t>(level ? (d.level | m) : (d.level & ~m));
  if (!d.hooked) {
    d.hooked = true;
    auto* all = avr_io_getirq(avr_, AVR_IOCTL_IOPORT_GETIRQ(port), IOPORT_IRQ_PIN_ALL);
    avr_irq_register_notify(all, &AvrMachine::port_write_hook, this);
  }
  avr_raise_irq(avr_io_getirq(avr_, AVR_IOCTL_IOPORT_GETIRQ(port), bit), level ? 1 : 0);
}

void AvrMachine::port_write_hook(avr_irq_t* irq, std::uint32_t, void* param) {
  auto* self = static_cast<AvrMachine*>(param);
  // which port: compare with the PIN_ALL irq of each driven port
  for (char port = 'B'; port <= 'D'; ++port) {
    if (!self->driven_[port - 'B'].hooked) continue;
    if (avr_io_getirq(self->avr_, AVR_IOCTL_IOPORT_GETIRQ(port), IOPORT_IRQ_PIN_ALL) == irq) {
      self->reassert(port);
    }
  }
}

void AvrMachine::reassert(char port) {
  if (reasserting_) return;
  reasserting_ = true;
  const Driven& d = driven_[port - 'B'];
  for (int bit = 0; bit < 8; ++bit) {
    if (!((d.mask >> bit) & 1)) continue;
    avr_irq_t* pin = avr_io_getirq(avr_, AVR_IOCTL_IOPORT_GETIRQ(port), bit);
    const std::uint32_t level = (d.level >> bit) & 1;
    // toggle first: simavr ignores a raise to the value the irq already holds
    avr_raise_irq(pin, level ^ 1u);
    avr_raise_irq(pin, level);
  }
  reasserting_ = false;
}

// simavr 1.6's EEPROM ioctls answer -1 when they succeed (and when no module handles them),
// -2 on a bad argument: success shows in what they did. GET without a buffer hands out the
// EEPROM's own memory.
std::span<const std::uint8_t> AvrMachine::eeprom() const {
  const std::uint32_t size = avr_->e2end + 1;
  avr_eeprom_desc_t desc{nullptr, 0, size};
  avr_ioctl(avr_, AVR_IOCTL_EEPROM_GET, &desc);
  if (desc.ee == nullptr) return {};
  return {desc.ee, size};
}

bool AvrMachine::set_eeprom(std::span<const std::uint8_t> bytes) {
  const auto now = eeprom();
  if (bytes.empty() || bytes.size() != now.size()) return false;
  std::vector<std::uint8_t> copy(bytes.begin(), bytes.end());
  avr_eeprom_desc_t desc{copy.data(), 0, static_cast<std::uint32_t>(copy.size())};
  avr_ioctl(avr_, AVR_IOCTL_EEPROM_SET, &desc);
  return std::equal(bytes.begin(), bytes.end(), now.begin());
}

std::span<const std::uint8_t> AvrMachine::flash() const {
  return {avr_->flash, static_cast<std::size_t>(avr_->flashend) + 1};
}

bool AvrMachine::set_flash(std::span<const std::uint8_t> bytes) {
  if (bytes.size() != flash().size()) return false;
  std::copy(bytes.begin(), bytes.end(), avr_->flash);
  return true;
}

bool AvrMachine::write_flash(std::uint32_t byte_address, std::span<const std::uint8_t> bytes) {
  if (byte_address > flash().size() || bytes.size() > flash().size() - byte_address) return false;
  std::copy(bytes.begin(), bytes.end(), avr_->flash + byte_address);
  return true;
}

void AvrMachine::set_reset_vector(std::uint32_t byte_address) {
  avr_->reset_pc = byte_address;
  avr_->pc = byte_address;  // power-up starts there too (MCUSR holds PORF)
}

bool AvrMachine::in_boot_section() const {
  return avr_->reset_pc != 0 && avr_->pc >= avr_->reset_pc;
}

void AvrMachine::reset_hook(avr_t* avr) {
  AvrMachine* self = nullptr;
  {
    std::lock_guard<std::mutex> lock(g_machines_mu);
    auto it = g_machines.find(avr);
    if (it != g_machines.end()) self = it->second;
  }
  if (self == nullptr) return;
  if (self->core_reset_ != nullptr) self->core_reset_(avr);
  ++self->resets_;
  self->reset_seen_ = true;
  self->reset_cycle_ = avr->cycle;
}

void AvrMachine::reset_external() {
  ++external_resets_;
  avr_reset(avr_);
  avr_regbit_set(avr_, avr_->reset_flags.extrf);
  after_reset();
}

bool AvrMachine::restart_blank_loop() {
  if (avr_->flash[0] != 0xff || avr_->flash[1] != 0xff) return false;
  // the stack pointer (SPH:SPL at 0x5e:0x5d) more than 256 bytes below the top of the RAM
  const unsigned sp = avr_->data[0x5d] | (static_cast<unsigned>(avr_->data[0x5e]) << 8);
  if (sp + 256 > avr_->ramend) return false;
  avr_reset(avr_);
  avr_regbit_set(avr_, avr_->reset_flags.porf);
  after_reset();
  return true;
}

void AvrMachine::after_reset() {
  if (!reset_seen_) return;
  reset_seen_ = false;
  // some simavr versions restart the cycle counter at a reset: the emulated clock goes on
  if (avr_->cycle < reset_cycle_) avr_->cycle = reset_cycle_;
  last_reset_cycle_ = avr_->cycle;
  // simavr's reset puts the UART's flags back to its defaults: STDIO (a console line per
  // newline) and POLL_SLEEP (a host sleep whenever the firmware polls an empty receiver),
  // which made an emulator three times slower after every open of its port
  fix_simavr_defaults(avr_);
  if (profile_period_ > 0) avr_cycle_timer_register(avr_, profile_period_, profile_hook, this);
  // the UART's receiver starts disabled and empty: simavr's back-pressure starts over
  xoff_ = false;
  for (char port = 'B'; port <= 'D'; ++port) {
    if (driven_[port - 'B'].hooked) reassert(port);
  }
}

void AvrMachine::on_uart_output(ByteCallback cb) { uart_out_ = std::move(cb); }

void AvrMachine::uart_send(std::uint8_t byte) {
  to_avr_.push_back(byte);
  feed_uart();
}

void AvrMachine::feed_uart() {
  while (!xoff_ && !to_avr_.empty()) {
    const std::uint8_t b = to_avr_.front();
    to_avr_.pop_front();
    avr_raise_irq(uart_in_, b);
  }
}

namespace {

// One-shot cycle timer at run_until's target.
avr_cycle_count_t stop_here(avr_t*, avr_cycle_count_t, void*) { return 0; }

}  // namespace

bool AvrMachine::run_until(std::uint64_t cycle) {
  // A sleeping AVR costs nothing here: each avr_run of a sleeping core advances the cycle
  // counter straight to the next cycle timer (a timer's compare or overflow, a UART byte, the
  // profiler) instead of emulating the idle cycles. The timer at the target ends such a skip
  // there (one cycle past), so a firmware asleep for milliseconds does not carry the emulated
  // clock that far ahead of the caller's pacing and input.
  if (avr_->cycle < cycle) avr_cycle_timer_register(avr_, cycle - avr_->cycle, stop_here, this);
  bool alive = true;
  while (alive && avr_->cycle < cycle) {
    const int state = avr_run(avr_);
    alive = state != cpu_Done && state != cpu_Crashed;
    if (reset_seen_) {
      // a watchdog reset (the bootloader leaving for the firmware, say) dropped the timers
      after_reset();
      if (avr_->cycle < cycle) avr_cycle_timer_register(avr_, cycle - avr_->cycle, stop_here, this);
    }
  }
  // a skip ends one cycle past the target, before simavr ran the timer: drop it
  avr_cycle_timer_cancel(avr_, stop_here, this);
  return alive;
}

std::uint64_t AvrMachine::cycle() const { return avr_->cycle; }

std::uint64_t AvrMachine::wake_cycle() const {
  if (avr_->state != cpu_Sleeping) return avr_->cycle;
  // simavr keeps its cycle timers sorted, the earliest first
  const avr_cycle_timer_slot_t* next = avr_->cycle_timers.timer;
  if (next == nullptr) return UINT64_MAX;
  return std::max<std::uint64_t>(next->when, avr_->cycle);
}

namespace {

avr_cycle_count_t profile_hook(avr_t* avr, avr_cycle_count_t when, void* param) {
  auto* self = static_cast<AvrMachine*>(param);
  self->profile_sample(avr->state == cpu_Sleeping, avr->pc);
  return when + self->profile_period();
}

}  // namespace

void AvrMachine::start_profile(std::uint32_t period_cycles) {
  profile_period_ = std::max<std::uint32_t>(period_cycles, 1);
  profile_pc_.assign(avr_->flashend / 2 + 1, 0);
  avr_cycle_timer_register(avr_, profile_period_, profile_hook, this);
}

void AvrMachine::profile_sample(bool sleeping, std::uint32_t pc) {
  if (sleeping) {
    ++profile_sleep_;
  } else if (pc / 2 < profile_pc_.size()) {
    ++profile_pc_[pc / 2];
  }
}

std::string AvrMachine::profile_table(int rows) const {
  // function symbols by address (simavr keeps the ELF's symbols sorted by name)
  std::map<std::uint32_t, std::string> functions;
  for (std::uint32_t i = 0; i < fw_->symbolcount; ++i) {
    const avr_symbol_t* sym = fw_->symbol[i];
    // code symbols only: data lives at 0x800000 and up in AVR ELF files; linker constants
    // such as __TEXT_REGION_LENGTH__ are not functions
    const std::string name = sym->symbol;
    const bool linker_constant =
        name.size() > 4 && name.rfind("__", 0) == 0 && name.compare(name.size() - 2, 2, "__") == 0;
    if (sym->addr >= 0x800000 || linker_constant) continue;
    int status = 0;
    char* demangled = abi::__cxa_demangle(name.c_str(), nullptr, nullptr, &status);
    functions.emplace(sym->addr, status == 0 && demangled != nullptr ? demangled : name);
    std::free(demangled);
  }
  std::map<std::string, std::uint64_t> by_name;
  std::uint64_t total = profile_sleep_;
  for (std::size_t w = 0; w < profile_pc_.size(); ++w) {
    if (profile_pc_[w] == 0) continue;
    total += profile_pc_[w];
    const auto addr = static_cast<std::uint32_t>(w * 2);
    auto it = functions.upper_bound(addr);
    char fallback[32];
    std::snprintf(fallback, sizeof fallback, "0x%05x", addr);
    by_name[it == functions.begin() ? fallback : std::prev(it)->second] += profile_pc_[w];
  }
  std::vector<std::pair<std::uint64_t, std::string>> sorted;
  for (const auto& [name, n] : by_name) sorted.emplace_back(n, name);
  std::sort(sorted.rbegin(), sorted.rend());
  std::string out;
  char line[256];
  const double t = total > 0 ? static_cast<double>(total) : 1.0;
  std::snprintf(line, sizeof line, "firmware CPU profile: %llu samples, one per %u cycles\n",
                static_cast<unsigned long long>(total), profile_period_);
  out += line;
  std::snprintf(line, sizeof line, "%7.2f %%  (sleeping)\n",
                100.0 * static_cast<double>(profile_sleep_) / t);
  out += line;
  for (int i = 0; i < rows && i < static_cast<int>(sorted.size()); ++i) {
    std::snprintf(line, sizeof line, "%7.2f %%  %s\n",
                  100.0 * static_cast<double>(sorted[i].first) / t, sorted[i].second.c_str());
    out += line;
  }
  return out;
}

}  // namespace scaratwin::robot
