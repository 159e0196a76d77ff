// Malformed input: every bad line is rejected with the right error code (docs/protocol.md
// section 6) and the packet after it is decoded correctly.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "scaratwin/protocol/codec.hpp"

namespace scaratwin::protocol {
namespace {

struct BadInput {
  const char* what;
  std::string bytes;
  int error;
};

template <typename Direction>
void check_rejected_then_recovered(const std::vector<BadInput>& corpus, const std::string& good,
                                   const Direction& expected) {
  for (const BadInput& bad : corpus) {
    SCOPED_TRACE(bad.what);
    StreamDecoder<Direction> d;
    const auto items = d.feed(bad.bytes + good);
    ASSERT_EQ(items.size(), 2u);
    ASSERT_EQ(items[0].index(), 1u) << "accepted";
    const DecodeError& e = std::get<1>(items[0]);
    EXPECT_EQ(e.code, bad.error) << e.message;
    EXPECT_FALSE(e.message.empty());
    ASSERT_EQ(items[1].index(), 0u) << std::get<1>(items[1]).message;
    EXPECT_EQ(std::get<0>(items[1]), expected);
  }
}

TEST(ProtocolMalformed, TcpToSim) {
  const std::vector<BadInput> corpus = {
      {"truncated", "JD,17,500\n", core::kErrBadCharacter},
      {"truncated fields", "JD,17,5000123,120,\n", core::kErrWrongFieldCount},
      {"truncated number", "JD,17,5000123,120,12.,0,0,\n", core::kErrBadNumber},
      {"no final delimiter", "RS\n", core::kErrBadCharacter},
      {"overlong", "JD," + std::string(2000, '9') + "\n", core::kErrLineTooLong},
      {"binary junk", std::string("\x00\xff\xfe\x13\x37junk", 9) + "\n", core::kErrBadCharacter},
      {"wrong field count", "GR,1,2,3,\n", core::kErrWrongFieldCount},  // state [robot]
      {"too many fields", "RS,1,2,3,4,5,6,7,8,9,10,11,12,13,\n", core::kErrWrongFieldCount},
      {"camera with one size", "CS,320,\n", core::kErrWrongFieldCount},
      {"NaN", "JD,1,2,nan,0,0,0,\n", core::kErrBadNumber},
      {"NaN upper", "JD,1,2,NaN,0,0,0,\n", core::kErrBadNumber},
      {"infinity", "SC,red,inf,0,\n", core::kErrBadNumber},
      {"exponent", "SC,red,1e308,0,\n", core::kErrBadNumber},
      {"huge decimal", "SC,red,12345678901234567890,0,\n", core::kErrBadNumber},
      {"huge integer", "GR,99999999999999999999,\n", core::kErrBadNumber},
      {"huge seq", "JD,65536,0,0,0,0,0,\n", core::kErrBadValue},
      {"negative timestamp", "JD,1,-5,0,0,0,0,\n", core::kErrBadNumber},
      {"comma decimal (locale)", "SC,red,1,5,0,\n", core::kErrWrongFieldCount},
      {"unknown code", "ZZ,1,\n", core::kErrUnknownCode},
      {"reply code sent to the simulator", "JA,1,2,\n", core::kErrUnknownCode},
      {"serial framing on TCP", "RS=\n", core::kErrBadCharacter},
      {"unknown mode", "MD,fly,\n", core::kErrBadValue},
      {"unknown twin phase", "TW,replay,\n", core::kErrBadValue},
      {"twin phase without its field", "TW,\n", core::kErrWrongFieldCount},
      {"unknown colour", "SC,purple,0,0,\n", core::kErrBadValue},
      {"grasp not 0 or 1", "GR,2,\n", core::kErrBadValue},
      {"space in field", "GR, 1,\n", core::kErrBadCharacter},
  };
  check_rejected_then_recovered<TcpToSim>(corpus, "RS,\n", TcpToSim(ResetScene{}));
}

TEST(ProtocolMalformed, TcpFromSim) {
  const std::vector<BadInput> corpus = {
      {"image too large", "IM,8388609,\n" + std::string(8388609, '\n'), core::kErrPayloadTooLarge},
      {"negative image size", "IM,-1,\n", core::kErrBadNumber},
      {"bad ack code", "AK,rs,\n", core::kErrBadValue},
      {"error code zero", "ER,0,\n", core::kErrBadValue},
      {"held id below -1", "GR,1,-2,\n", core::kErrBadValue},
      {"joint warning joint 5", "JW,5,1,\n", core::kErrBadValue},
      {"NaN pose", "OP,1,red,nan,0,0,0,\n", core::kErrBadNumber},
      {"request code from the simulator", "JD,1,2,0,0,0,0,\n", core::kErrUnknownCode},
  };
  check_rejected_then_recovered<TcpFromSim>(corpus, "AK,RS,\n", TcpFromSim(Ack{"RS", {}}));
}

TEST(ProtocolMalformed, SerialToDevice) {
  const std::vector<BadInput> corpus = {
      {"truncated", "TP=1=500=1=\n", core::kErrWrongFieldCount},
      {"truncated mid-field", "TP=1=500=1\n", core::kErrBadCharacter},
      {"overlong", "TP=" + std::string(97, '1') + "=\n", core::kErrLineTooLong},
      {"binary junk", std::string("\x01\x02\x03\xff\x80", 5) + "\n", core::kErrBadCharacter},
      {"decimal on the serial link", "GR=75.5=\n", core::kErrBadNumber},
      {"NaN", "GR=nan=\n", core::kErrBadNumber},
      {"huge number", "JG=1=4294967296=\n", core::kErrBadNumber},
      {"wrong field count", "JG=1=\n", core::kErrWrongFieldCount},
      {"unknown code", "XY=\n", core::kErrUnknownCode},
      {"TCP framing on serial", "SP,\n", core::kErrBadCharacter},
      {"rate out of range", "SR=5000=\n", core::kErrBadValue},
      {"trajectory of zero points", "TB=0=\n", core::kErrBadValue},
      {"dt of zero", "TP=0=0=1=2=3=4=\n", core::kErrBadValue},
      {"axis 7", "JG=7=10=\n", core::kErrBadValue},
      {"unknown setting", "CF=99=\n", core::kErrBadValue},
      {"setting after the last one", "CF=12=\n", core::kErrBadValue},
  };
  check_rejected_then_recovered<SerialToDevice>(corpus, "SP=\n", SerialToDevice(Stop{}));
}

// Every key of the firmware's settings table (docs/firmware.md: 1..11) decodes, the last one
// (the serial rate) and the companion dialect's included.
TEST(ProtocolMalformed, EverySettingKeyOfTheFirmwareDecodes) {
  SerialToDeviceDecoder d;
  const auto items = d.feed("CF=7=\nCF=10=1=\nCF=11=1152=\n");
  ASSERT_EQ(items.size(), 3u);
  EXPECT_EQ(std::get<0>(items[0]), SerialToDevice(Config{7, std::nullopt}));
  EXPECT_EQ(std::get<0>(items[1]), SerialToDevice(Config{10, 1}));
  EXPECT_EQ(std::get<0>(items[2]), SerialToDevice(Config{11, 1152}));
}

TEST(ProtocolMalformed, SerialFromDevice) {
  const std::vector<BadInput> corpus = {
      {"truncated state", "ST=1=2=3=\n", core::kErrWrongFieldCount},
      {"binary junk", "\x7f\n", core::kErrBadCharacter},
      {"real-time byte from the device", "EV=6=!\n", core::kErrBadCharacter},
      {"unknown event", "EV=99=\n", core::kErrBadValue},
      {"event after the last one", "EV=13=\n", core::kErrBadValue},
      {"seq above 65535", "ST=70000=1=0=0=0=0=0=0=0=\n", core::kErrBadValue},
      {"text in a number field", "ER=abc=\n", core::kErrBadNumber},
      {"number too long for u32", "ST=1=99999999999=0=0=0=0=0=0=0=\n", core::kErrBadNumber},
  };
  check_rejected_then_recovered<SerialFromDevice>(corpus, "AK=SP=\n",
                                                  SerialFromDevice(Ack{"SP", {}}));
}

TEST(ProtocolMalformed, TruncatedPacketSwallowsOnlyTheLineItJoins) {
  TcpToSimDecoder d;
  const auto items = d.feed("JD,17,500RS,\nRS,\n");  // "JD,17,500" lost its end
  ASSERT_EQ(items.size(), 2u);
  EXPECT_EQ(std::get<1>(items[0]).code, core::kErrWrongFieldCount);
  EXPECT_EQ(std::get<0>(items[1]), TcpToSim(ResetScene{}));
}

TEST(ProtocolMalformed, ErrorMessagesNameTheBadValue) {
  TcpToSimDecoder d;
  const auto items = d.feed("SC,red,nan,0,\nZZ,\nGR,1,2,3,\nMD,fly,\n");
  ASSERT_EQ(items.size(), 4u);
  EXPECT_NE(std::get<1>(items[0]).message.find("'nan'"), std::string::npos)
      << std::get<1>(items[0]).message;
  EXPECT_EQ(std::get<1>(items[0]).detail, 1);
  EXPECT_NE(std::get<1>(items[1]).message.find("ZZ"), std::string::npos);
  EXPECT_NE(std::get<1>(items[1]).message.find("JD"), std::string::npos);  // lists valid codes
  EXPECT_NE(std::get<1>(items[2]).message.find("expects 1..2"), std::string::npos)
      << std::get<1>(items[2]).message;
  EXPECT_NE(std::get<1>(items[3]).message.find("mirror, simulate"), std::string::npos);
}

}  // namespace
}  // namespace scaratwin::protocol
