// The firmware's command handling built for the host: see firmware_host.hpp.
#include "firmware_host.hpp"

#include <algorithm>
#include <cstring>
#include <string_view>
#include <vector>

#include "avr/io.h"
#include "controller.h"
#include "fw_config.h"
#include "mechanics.hpp"
#include "scaratwin/protocol/codec.hpp"

extern "C" void fw_isr_USART_RX_vect(void);
extern "C" void fw_isr_USART_UDRE_vect(void);
extern "C" void fw_isr_TIMER0_OVF_vect(void);
extern "C" void fw_isr_TIMER2_COMPA_vect(void);

#if defined(__clang__)
// the firmware's variables (fw_host_state.h), bounds from the linker
extern "C" char __start_fw_host_bss[], __stop_fw_host_bss[];
extern "C" char __start_fw_host_data[], __stop_fw_host_data[];
#endif

namespace scaratwin::fuzz {
namespace {

constexpr std::uint64_t kTickUs = 1000000 / fw::kTickHz;  // 50 us
constexpr std::uint64_t kByteUs = 87;                     // 10 bits at 115200 baud
constexpr std::uint64_t kTailUs = 100000;
constexpr std::uint8_t kWaitByte = 0xff;  // not sent: the host waits 20 ms
constexpr std::uint64_t kWaitUs = 20000;

#if defined(__clang__)
// Byte copies that ASan does not check: the sections hold the globals' redzones too.
__attribute__((no_sanitize("address"))) void copy_bytes(char* to, const char* from, std::size_t n) {
  for (std::size_t i = 0; i < n; ++i) static_cast<volatile char*>(to)[i] = from[i];
}

struct Snapshot {
  std::vector<char> bss, data;
  Snapshot()
      : bss(static_cast<std::size_t>(__stop_fw_host_bss - __start_fw_host_bss)),
        data(static_cast<std::size_t>(__stop_fw_host_data - __start_fw_host_data)) {
    copy_bytes(bss.data(), __start_fw_host_bss, bss.size());
    copy_bytes(data.data(), __start_fw_host_data, data.size());
  }
  void restore() const {
    copy_bytes(__start_fw_host_bss, bss.data(), bss.size());
    copy_bytes(__start_fw_host_data, data.data(), data.size());
  }
};
#endif

class Host {
 public:
  Host() : mech_(config()) {}

  std::string run(const std::uint8_t* data, std::size_t size) {
    fw::controller_init();
    drain();
    for (std::size_t i = 0; i < size; ++i) {
      if (data[i] == kWaitByte) {
        wait(kWaitUs);
        continue;
      }
      UDR0 = data[i];
      fw_isr_USART_RX_vect();
      advance(kByteUs);
      poll();
    }
    wait(kTailUs);
    return std::move(out_);
  }

 private:
  static robot::MechanicsConfig config() {
    robot::MechanicsConfig c;
    // powered on a little short of its switches, so that a homing takes a fraction of a
    // second of emulated time (and of the fuzzer's)
    const std::int32_t j2 = fw::desc::kEndstopJ2 - 30 * fw::desc::kHomingDirJ2;
    c.start_steps = {fw::desc::kEndstopZ - 30 * fw::desc::kHomingDirZ, j2,
                     fw::desc::kEndstopJ3 + fw::desc::kCouplingPermille * j2 / 1000 -
                         30 * fw::desc::kHomingDirJ3};
    c.z_endstop = fw::desc::kEndstopZ;
    c.j2_endstop = fw::desc::kEndstopJ2;
    c.j3_endstop = fw::desc::kEndstopJ3;
    c.coupling_permille = fw::desc::kCouplingPermille;
    c.servo_min_us = fw::desc::kServoMinUs;
    c.servo_max_us = fw::desc::kServoMaxUs;
    c.servo_min_deg = 0.0;
    c.servo_max_deg = 180.0;
    return c;
  }

  // time passes with the main loop running
  void wait(std::uint64_t us) {
    for (std::uint64_t t = 0; t < us; t += 1000) {
      advance(1000);
      poll();
    }
  }
  // the main loop's pass, then the transmit interrupt until the ring is empty
  void poll() {
    fw::controller_poll();
    drain();
  }
  void drain() {
    for (;;) {
      fw_isr_USART_UDRE_vect();
      if (!(UCSR0B & (1u << UDRIE0))) return;
      out_.push_back(static_cast<char>(UDR0));
    }
  }

  // emulated time: the clock's counter and overflow, the step tick while its timer runs, the
  // pins it drives into the mechanics and the switches back into the pins
  void advance(std::uint64_t us) {
    const std::uint64_t end = now_us_ + us;
    while (now_us_ < end) {
      if (step_timer_runs()) {
        now_us_ += kTickUs;
      } else {
        // the step timer stopped: until the clock's next overflow (or the end), no code of the
        // firmware runs and no pin changes, so those ticks are taken in one stride (the same
        // ticks, landing where tick by tick would)
        const std::uint64_t to = std::min(end, next_overflow_us_);
        now_us_ += std::max<std::uint64_t>(1, (to - now_us_ + kTickUs - 1) / kTickUs) * kTickUs;
      }
      TCNT0 = static_cast<std::uint8_t>((now_us_ % 1024) / 4);
      while (now_us_ >= next_overflow_us_) {
        next_overflow_us_ += 1024;
        if (TIMSK0 & (1u << TOIE0)) fw_isr_TIMER0_OVF_vect();
      }
      if (step_timer_runs()) {
        fw_isr_TIMER2_COMPA_vect();
        pins();
      }
    }
  }
  static bool step_timer_runs() { return TCCR2B != 0 && (TIMSK2 & (1u << OCIE2A)); }
  void pins() {
    const std::uint8_t d = PORTD;
    for (int a = 0; a < robot::kAxes; ++a) {
      mech_.on_dir(a, (d >> (5 + a)) & 1u);
      mech_.on_step(a, (d >> (2 + a)) & 1u, now_us_);
    }
    // switches on PB1..3, closed pulls low; buttons PB4, PB5 released (high)
    const std::uint8_t closed = mech_.endstops();
    std::uint8_t b = 0xff;
    for (int a = 0; a < robot::kAxes; ++a) {
      if ((closed >> a) & 1u) b = static_cast<std::uint8_t>(b & ~(1u << (1 + a)));
    }
    PINB = b;
  }

  robot::Mechanics mech_;
  std::uint64_t now_us_ = 0;
  std::uint64_t next_overflow_us_ = 1024;
  std::string out_;
};

// One value of a periodic report in the single-class form (setting 10 = 2, docs/firmware.md):
// `t<us>`, `z`, `y`, `x<steps>`, `w`, `g<cdeg>`, then '\n'; t is unsigned.
bool single_class_line(std::string_view line) {
  if (line.size() < 3 || std::string_view("tzyxwg").find(line[0]) == std::string_view::npos) {
    return false;
  }
  std::size_t i = 1;
  if (line[0] != 't' && line[i] == '-') ++i;
  const std::size_t digits_from = i;
  while (i < line.size() && line[i] >= '0' && line[i] <= '9') ++i;
  return i > digits_from && i + 1 == line.size() && line[i] == '\n';
}

}  // namespace

bool firmware_starts_fresh() {
#if defined(__clang__)
  return true;
#else
  return false;
#endif
}

std::string run_firmware(const std::uint8_t* data, std::size_t size) {
#if defined(__clang__)
  static const Snapshot reset;  // the firmware's variables before it ever ran
  reset.restore();
#endif
  Host host;
  return host.run(data, size);
}

std::string check_firmware_commands(const std::uint8_t* data, std::size_t size) {
  const std::string out = run_firmware(data, size);
  if (out.rfind("HI=", 0) != 0) return "the first line is not the hello: " + out.substr(0, 40);
  if (out.back() != '\n') return "the output ends inside a line: " + out.substr(out.size() - 40);
  protocol::StreamDecoder<protocol::SerialFromDevice> decoder;
  for (std::size_t at = 0; at < out.size();) {
    const std::size_t nl = out.find('\n', at);
    const std::string_view line(out.data() + at, nl + 1 - at);
    at = nl + 1;
    if (line.rfind("error: ", 0) == 0) continue;  // the companion dialect's error line
    if (single_class_line(line)) continue;        // a report in the single-class form (CF 10 = 2)
    std::string violation;
    decoder.feed(line, [&](protocol::Decoded<protocol::SerialFromDevice>&& item) {
      if (item.index() == 1) {
        violation = "the firmware sent a line the host cannot decode: '" +
                    std::string(line.substr(0, line.size() - 1)) + "' (" +
                    std::get<1>(item).message + ")";
      }
    });
    if (!violation.empty()) return violation;
  }
  return {};
}

}  // namespace scaratwin::fuzz
