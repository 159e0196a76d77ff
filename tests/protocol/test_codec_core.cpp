// Byte-level codec core: framing, validation, resync, real-time bytes, payloads, encoder.
#include <gtest/gtest.h>

#include <cstring>
#include <random>
#include <string>
#include <vector>

#include "core_trace.hpp"
#include "scaratwin/protocol/codec_core.h"

namespace scaratwin::protocol {
namespace {

using core::code_id;
using test::core_trace;
using Trace = std::vector<std::string>;

TEST(CodecCore, DecodesBothFramings) {
  EXPECT_EQ(core_trace(core::kTcpHubToSim, "JD,17,5000123,120,12.5,-30.25,90,\n"),
            Trace{"P JD 17|5000123|120|12.5|-30.25|90|"});
  EXPECT_EQ(core_trace(core::kSerialDeviceToHost, "ST=1=4294967295=-5=0=7=9000=0=3=8=\r\n"),
            Trace{"P ST 1|4294967295|-5|0|7|9000|0|3|8|"});
  EXPECT_EQ(core_trace(core::kSerialHostToDevice, "SP=\n"), Trace{"P SP "});
}

TEST(CodecCore, ParsesIntegerFieldsAtTheirLimits) {
  std::vector<char> buf(96);
  core::Decoder d(core::kSerialHostToDevice, buf.data(), 96);
  core::Event ev{};
  const std::string line = "JG=-2147483648=2147483647=\n";
  d.feed(reinterpret_cast<const std::uint8_t*>(line.data()), line.size(), &ev);
  ASSERT_EQ(ev.type, core::kEventPacket);
  EXPECT_EQ(d.packet().i32(0), INT32_MIN);
  EXPECT_EQ(d.packet().i32(1), INT32_MAX);
  EXPECT_EQ(core_trace(core::kSerialHostToDevice, "JG=1=2147483648=\n"), Trace{"E 5 1 JG"});
  EXPECT_EQ(core_trace(core::kSerialHostToDevice, "JG=-2147483649=0=\n"), Trace{"E 5 0 JG"});
  EXPECT_EQ(core_trace(core::kSerialDeviceToHost, "ST=1=4294967296=0=0=0=0=0=0=0=\n"),
            Trace{"E 5 1 ST"});
  EXPECT_EQ(core_trace(core::kSerialDeviceToHost, "ST=1=-1=0=0=0=0=0=0=0=\n"), Trace{"E 5 1 ST"});
}

TEST(CodecCore, RejectsEachKindOfBadLineAndResyncs) {
  struct Case {
    std::string line;
    std::string expected;
  };
  const std::vector<Case> cases = {
      {"JD,1,2,", "E 4 2 JD"},                                 // wrong field count
      {"XX,", "E 3 0 XX"},                                     // unknown code
      {"JD,1,2,nan,0,0,0,", "E 5 2 JD"},                       // NaN
      {"JD,1,2,inf,0,0,0,", "E 5 2 JD"},                       // infinity
      {"JD,1,2,1e3,0,0,0,", "E 5 2 JD"},                       // exponent
      {"JD,1,2,+1,0,0,0,", "E 5 2 JD"},                        // leading plus
      {"JD,1,2,1.,0,0,0,", "E 5 2 JD"},                        // no fraction digits
      {"JD,1,2,.5,0,0,0,", "E 5 2 JD"},                        // no integer digits
      {"JD,1,2,,0,0,0,", "E 5 2 JD"},                          // empty field
      {"JD,1,2,1234567890,0,0,0,", "E 5 2 JD"},                // 10 significant digits
      {"JD,1,2,1.1234567,0,0,0,", "E 5 2 JD"},                 // 7 fraction digits
      {"JD,99999999999,2,0,0,0,0,", "E 5 0 JD"},               // huge integer
      {"JD,1,2,3,4,5,6", "E 2 14 JD"},                         // no final delimiter
      {"JD;1,2,3,4,5,6,", "E 2 2"},                            // bad delimiter after the code
      {"jd,1,2,3,4,5,6,", "E 2 0"},                            // lower-case code
      {"MD,Mir ror,", "E 2 6"},                                // space
      {"MD,mi!rror,", "E 2 5 MD"},                             // bad text character
      {std::string("JD,1,\x01,3,", 9), "E 2 5"},               // control byte
      {"\xff\xfe\x80garbage", "E 2 0"},                        // binary junk
      {"MD,abcdefghijabcdefghijabcdefghijabc,", "E 2 35 MD"},  // text too long
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.line);
    EXPECT_EQ(core_trace(core::kTcpHubToSim, c.line + "\nRS,\n"), (Trace{c.expected, "P RS "}));
  }
}

TEST(CodecCore, OverlongLineIsReportedOnceAndResyncsAtNewline) {
  const std::string longline = "JD," + std::string(600, '1') + ",\nRS,\n";
  EXPECT_EQ(core_trace(core::kTcpHubToSim, longline), (Trace{"E 1 512", "P RS "}));
  // exactly at the limit: 95 bytes + '\n' = 96 is fine, 97 is not.
  std::string fits = "PI=" + std::string(91, '0') + "=";
  ASSERT_EQ(fits.size() + 1, 96u);
  EXPECT_EQ(core_trace(core::kSerialHostToDevice, fits + "\n").at(0)[0], 'P');
  EXPECT_EQ(core_trace(core::kSerialHostToDevice, "0" + fits + "\nSP=\n"),
            (Trace{"E 1 96", "P SP "}));
  // a smaller caller buffer lowers the limit.
  EXPECT_EQ(core_trace(core::kTcpHubToSim, "PI,12345,\nRS,\n", {}, 8), (Trace{"E 1 9", "P RS "}));
}

TEST(CodecCore, EmptyLinesAreIgnored) {
  EXPECT_EQ(core_trace(core::kTcpHubToSim, "\n\r\n\nRS,\n"), Trace{"P RS "});
}

TEST(CodecCore, RealtimeBytesAreTakenOutMidLine) {
  EXPECT_EQ(core_trace(core::kSerialHostToDevice, "TP=5=50!0=1=2=3=4=\n~#"),
            (Trace{"R !", "P TP 5|500|1|2|3|4|", "R ~", "R #"}));
  // also while discarding an overlong line.
  EXPECT_EQ(core_trace(core::kSerialHostToDevice, std::string(120, '1') + "!\nSP=\n"),
            (Trace{"E 1 96", "R !", "P SP "}));
  // on links without real-time bytes they are bad characters.
  EXPECT_EQ(core_trace(core::kSerialDeviceToHost, "EV=6=!\n"), Trace{"E 2 6 EV"});
}

TEST(CodecCore, PayloadFollowsImageHeaderAndMayContainNewlines) {
  const std::string png("\x89PNG\r\n\x1a\n\0\n", 10);
  const std::string stream = "IM,10,\n" + png + "AK,RS,\n";
  const Trace expected{"P IM 10|", "B " + png, "P AK RS|"};
  EXPECT_EQ(core_trace(core::kTcpSimToHub, stream), expected);
  for (std::size_t cut = 0; cut <= stream.size(); ++cut) {
    EXPECT_EQ(core_trace(core::kTcpSimToHub, stream, {cut}), expected) << cut;
  }
  EXPECT_EQ(core_trace(core::kTcpSimToHub, "IM,0,\nAK,RS,\n"), (Trace{"P IM 0|", "P AK RS|"}));
}

TEST(CodecCore, OversizedPayloadIsSkippedExactly) {
  std::vector<char> line(512);
  core::LinkSpec small = core::kTcpSimToHub;
  small.max_payload = 4;
  EXPECT_EQ(core_trace(small, "IM,6,\n\n\n\n\n\n\nAK,RS,\n"), (Trace{"E 12 4 IM", "P AK RS|"}));
  EXPECT_EQ(core_trace(small, "IM,-6,\nAK,RS,\n"), (Trace{"E 5 0 IM", "P AK RS|"}));
}

TEST(CodecCore, AnyChunkingGivesTheSameEvents) {
  std::string stream;
  stream += "JD,17,5000123,120,12.5,-30.25,90,\nGR,1,\r\nCS,320,240,\n";
  stream += "XX,\nJD,1,2,\n" + std::string(700, 'z') + "\nMD,simulate,\n";
  stream += std::string("\x01\x02\xff\n", 4) + "OP,\nSC,red,10.5,-20,\n";
  const Trace whole = core_trace(core::kTcpHubToSim, stream);
  ASSERT_EQ(whole.size(), 10u);
  std::mt19937 rng(1234);
  for (int run = 0; run < 300; ++run) {
    const auto cuts = test::random_cuts(stream.size(), rng, 1 + static_cast<std::size_t>(run % 40));
    ASSERT_EQ(core_trace(core::kTcpHubToSim, stream, cuts), whole) << "run " << run;
  }
}

TEST(CodecCore, FixedPointRoundsHalfAwayFromZero) {
  std::vector<char> buf(512);
  core::Decoder d(core::kTcpHubToSim, buf.data(), 512);
  core::Event ev{};
  const std::string line = "SC,red,12.345,-0.0005,\n";
  d.feed(reinterpret_cast<const std::uint8_t*>(line.data()), line.size(), &ev);
  ASSERT_EQ(ev.type, core::kEventPacket);
  std::int32_t v = 0;
  ASSERT_TRUE(d.packet().fixed(1, 2, &v));
  EXPECT_EQ(v, 1235);
  ASSERT_TRUE(d.packet().fixed(1, 6, &v));
  EXPECT_EQ(v, 12345000);
  ASSERT_TRUE(d.packet().fixed(2, 3, &v));
  EXPECT_EQ(v, -1);
  EXPECT_FALSE(d.packet().fixed(1, 9, &v));  // 1.2345e10 does not fit
  EXPECT_TRUE(d.packet().text_equals(0, "red"));
  EXPECT_FALSE(d.packet().text_equals(0, "re"));
}

TEST(CodecCore, EncoderWritesTrimmedFixedPointAndSeveralPackets) {
  char buf[128];
  core::Encoder e(core::kTcpHubToSim, buf, sizeof buf);
  e.begin(code_id('J', 'D'));
  e.add_i32(17);
  e.add_u32(4294967295u);
  e.add_fixed(120000, 3);
  e.add_fixed(125000, 4);
  e.add_fixed(-302500, 4);
  e.add_fixed(-5, 4);
  ASSERT_TRUE(e.end());
  e.begin(code_id('R', 'S'));
  ASSERT_TRUE(e.end());
  EXPECT_EQ(std::string(e.data(), e.size()), "JD,17,4294967295,120,12.5,-30.25,-0.0005,\nRS,\n");
  EXPECT_EQ(e.error(), core::kErrNone);
}

TEST(CodecCore, EncoderRollsBackABadPacket) {
  char buf[16];
  core::Encoder e(core::kSerialHostToDevice, buf, sizeof buf);
  e.begin(code_id('S', 'P'));
  ASSERT_TRUE(e.end());
  e.begin(code_id('T', 'P'));  // does not fit in 16 bytes
  for (int i = 0; i < 6; ++i) e.add_i32(100000 + i);
  EXPECT_FALSE(e.end());
  EXPECT_EQ(e.error(), core::kErrLineTooLong);
  EXPECT_EQ(std::string(e.data(), e.size()), "SP=\n");

  char big[256];
  core::Encoder f(core::kSerialHostToDevice, big, sizeof big);
  f.begin(code_id('S', 'P'));
  f.add_i32(1);  // SP has no fields
  EXPECT_FALSE(f.end());
  EXPECT_EQ(f.error(), core::kErrWrongFieldCount);
  f.clear();
  f.begin(code_id('Z', 'Z'));
  EXPECT_FALSE(f.end());
  EXPECT_EQ(f.error(), core::kErrUnknownCode);
  f.clear();
  core::Encoder g(core::kTcpHubToSim, big, sizeof big);
  g.begin(code_id('M', 'D'));
  g.add_text("Bad mode");
  EXPECT_FALSE(g.end());
  EXPECT_EQ(g.error(), core::kErrBadValue);
  EXPECT_EQ(g.size(), 0u);
}

TEST(CodecCore, EncoderRespectsTheLineLimitOfTheLink) {
  char buf[1024];
  core::Encoder e(core::kSerialHostToDevice, buf, sizeof buf);
  e.begin(code_id('T', 'P'));
  for (int i = 0; i < 7; ++i) e.add_i32(-2000000000);
  EXPECT_TRUE(e.end());  // 3 + 7 * 12 + 1 = 88 bytes
  e.begin(code_id('H', 'I'));
  e.add_i32(1);
  EXPECT_TRUE(e.end());
  core::Encoder t(core::kTcpSimToHub, buf, sizeof buf);
  t.begin(code_id('H', 'I'));
  t.add_i32(1);
  t.add_text(std::string(32, 'a').c_str());
  t.add_text("0.1.0");
  EXPECT_TRUE(t.end());
}

TEST(CodecCore, ErrorNamesCoverTheTable) {
  for (std::uint8_t c = 0; c <= core::kErrMaxCode; ++c) {
    EXPECT_STRNE(core::error_name(c), "unknown") << int(c);
  }
  EXPECT_STREQ(core::error_name(core::kErrLineTooLong), "line_too_long");
}

}  // namespace
}  // namespace scaratwin::protocol
