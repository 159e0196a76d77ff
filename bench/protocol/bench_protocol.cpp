// Protocol codec throughput on one core: decoded joint-state packets per second for the
// byte-level core decoder and the typed host decoders, plus the encoders, printed as a table.
// Joint-state packets are the serial ST report (device -> host, integers) and the TCP JD
// packet (hub -> simulator, decimals). Input is fed in 4 KiB chunks, as from a socket read.
//
//   bench_protocol [seconds_per_case]   (default 0.5)
#include <time.h>

#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <random>
#include <string>
#include <string_view>
#include <vector>

#include "scaratwin/core/units.hpp"
#include "scaratwin/protocol/codec.hpp"
#include "scaratwin/protocol/codec_core.h"

namespace {

using namespace scaratwin;
using namespace scaratwin::protocol;

constexpr std::size_t kChunk = 4096;
constexpr std::size_t kPackets = 20000;

// CPU time of this thread: the machine may be shared, and the figure is per core.
double thread_cpu_s() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) + static_cast<double>(ts.tv_nsec) * 1e-9;
}

// Runs `pass` (which handles `per_pass` packets) repeatedly for `seconds` of CPU time;
// returns the best packets per CPU second of three runs.
double rate(double seconds, std::size_t per_pass, const std::function<void()>& pass) {
  double best = 0.0;
  for (int run = 0; run < 3; ++run) {
    std::size_t done = 0;
    const double start = thread_cpu_s();
    double elapsed = 0.0;
    do {
      pass();
      done += per_pass;
      elapsed = thread_cpu_s() - start;
    } while (elapsed < seconds / 3.0);
    best = std::max(best, static_cast<double>(done) / elapsed);
  }
  return best;
}

std::string serial_states(std::mt19937& rng) {
  std::uniform_int_distribution<std::int32_t> steps(-30000, 30000);
  std::string out;
  for (std::size_t i = 0; i < kPackets; ++i) {
    DeviceState s;
    s.seq = static_cast<std::uint16_t>(i);
    s.t_us = static_cast<std::uint32_t>(1000000 + i * 2000);
    s.steps = {steps(rng), steps(rng), steps(rng)};
    s.wrist_rad = deg_to_rad(45);
    s.grip_rad = deg_to_rad(75);
    s.flags = 3;
    s.queue_free = 8;
    if (!append(out, SerialFromDevice(s)).ok()) std::abort();
  }
  return out;
}

std::vector<JointData> joint_data(std::mt19937& rng) {
  std::uniform_real_distribution<double> angle(-1.5, 1.5);
  std::uniform_real_distribution<double> d1(0.01, 0.12);
  std::vector<JointData> out;
  for (std::size_t i = 0; i < kPackets; ++i) {
    out.push_back(JointData{static_cast<std::uint16_t>(i),
                            static_cast<std::uint32_t>(i * 2000),
                            {d1(rng), angle(rng), angle(rng), angle(rng)}});
  }
  return out;
}

std::string tcp_joint_data(const std::vector<JointData>& data) {
  std::string out;
  for (const JointData& j : data) {
    if (!append(out, TcpToSim(j)).ok()) std::abort();
  }
  return out;
}

// Core decoder over the whole stream; returns a checksum so the work is not optimized away.
std::int64_t core_decode(const core::LinkSpec& link, std::string_view bytes) {
  static char line[core::kTcpMaxLine];
  core::Decoder d(link, line, sizeof line);
  std::int64_t sum = 0;
  for (std::size_t at = 0; at < bytes.size(); at += kChunk) {
    const auto* p = reinterpret_cast<const std::uint8_t*>(bytes.data()) + at;
    std::size_t left = std::min(kChunk, bytes.size() - at);
    while (left > 0) {
      core::Event ev;
      const std::size_t used = d.feed(p, left, &ev);
      p += used;
      left -= used;
      if (ev.type == core::kEventPacket) sum += d.packet().value[0] + d.packet().field_count;
    }
  }
  return sum;
}

template <typename Direction, typename Sink>
void typed_decode(StreamDecoder<Direction>& d, std::string_view bytes, Sink&& sink) {
  for (std::size_t at = 0; at < bytes.size(); at += kChunk) {
    d.feed(bytes.substr(at, std::min(kChunk, bytes.size() - at)), sink);
  }
}

}  // namespace

int main(int argc, char** argv) {
  const double seconds = argc > 1 ? std::atof(argv[1]) : 0.5;
  std::mt19937 rng(7);
  const std::string st = serial_states(rng);
  const auto jd_messages = joint_data(rng);
  const std::string jd = tcp_joint_data(jd_messages);
  volatile std::int64_t sink = 0;

  struct Row {
    const char* what;
    double per_s;
    double bytes_per_packet;
  };
  std::vector<Row> rows;
  const double st_len = static_cast<double>(st.size()) / kPackets;
  const double jd_len = static_cast<double>(jd.size()) / kPackets;

  rows.push_back(
      {"core decoder, serial ST (device -> host)",
       rate(seconds, kPackets, [&] { sink = sink + core_decode(core::kSerialDeviceToHost, st); }),
       st_len});
  rows.push_back(
      {"core decoder, TCP JD (hub -> sim)",
       rate(seconds, kPackets, [&] { sink = sink + core_decode(core::kTcpHubToSim, jd); }),
       jd_len});
  {
    SerialFromDeviceDecoder d;
    rows.push_back({"typed decoder, serial ST -> DeviceState",
                    rate(seconds, kPackets,
                         [&] {
                           typed_decode(d, st, [&](Decoded<SerialFromDevice>&& m) {
                             if (const auto* s = std::get_if<0>(&m)) {
                               sink = sink + std::get<DeviceState>(*s).steps[0];
                             }
                           });
                         }),
                    st_len});
  }
  {
    TcpToSimDecoder d;
    rows.push_back({"typed decoder, TCP JD -> JointData",
                    rate(seconds, kPackets,
                         [&] {
                           typed_decode(d, jd, [&](Decoded<TcpToSim>&& m) {
                             if (const auto* s = std::get_if<0>(&m)) {
                               sink = sink + std::get<JointData>(*s).seq;
                             }
                           });
                         }),
                    jd_len});
  }
  rows.push_back({"core encoder, serial ST",
                  rate(seconds, kPackets,
                       [&] {
                         char buf[core::kSerialMaxLine];
                         for (std::size_t i = 0; i < kPackets; ++i) {
                           core::Encoder e(core::kSerialDeviceToHost, buf, sizeof buf);
                           e.begin(core::code_id('S', 'T'));
                           e.add_i32(static_cast<std::int32_t>(i & 0xffff));
                           e.add_u32(static_cast<std::uint32_t>(i * 2000));
                           e.add_i32(static_cast<std::int32_t>(i));
                           e.add_i32(-1200);
                           e.add_i32(2000);
                           e.add_i32(4500);
                           e.add_i32(7500);
                           e.add_i32(3);
                           e.add_i32(8);
                           e.end();
                           sink = sink + static_cast<std::int64_t>(e.size());
                         }
                       }),
                  st_len});
  rows.push_back({"typed encoder, JointData -> TCP JD",
                  rate(seconds, kPackets,
                       [&] {
                         std::string out;
                         out.reserve(jd.size());
                         for (const JointData& j : jd_messages) {
                           if (!append(out, TcpToSim(j)).ok()) std::abort();
                         }
                         sink = sink + static_cast<std::int64_t>(out.size());
                       }),
                  jd_len});

  std::printf("%-44s %14s %10s %12s\n", "case (per CPU second, 4 KiB chunks)", "packets/s",
              "bytes/pkt", "MB/s");
  for (const Row& r : rows) {
    std::printf("%-44s %14.0f %10.1f %12.1f\n", r.what, r.per_s, r.bytes_per_packet,
                r.per_s * r.bytes_per_packet / 1e6);
  }
  std::printf("target: >= 5,000,000 decoded joint-state packets/s per core\n");
  return 0;
}
