// Typed host layer: golden packets of every code in both framings, round trips, random
// chunking, SI conversion and value checks.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <fstream>
#include <random>
#include <sstream>
#include <string>

#include "samples.hpp"
#include "scaratwin/protocol/codec.hpp"

namespace scaratwin::protocol {
namespace {

std::string golden_path(const std::string& name) {
  return std::string(SCARATWIN_PROTOCOL_GOLDEN_DIR) + "/" + name;
}

std::string read_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

template <typename Direction>
std::string encode_all(const std::vector<Direction>& messages) {
  std::string out;
  for (const Direction& m : messages) {
    const Status s = append(out, m);
    EXPECT_TRUE(s.ok()) << (s.ok() ? "" : s.error().message);
  }
  return out;
}

template <typename Direction>
std::vector<Direction> decode_all(std::string_view bytes, std::vector<DecodeError>* errors) {
  StreamDecoder<Direction> decoder;
  std::vector<Direction> out;
  decoder.feed(bytes, [&](Decoded<Direction>&& d) {
    if (auto* m = std::get_if<0>(&d)) {
      out.push_back(std::move(*m));
    } else {
      errors->push_back(std::get<1>(d));
    }
  });
  return out;
}

// Every sample encodes to the golden bytes, and the golden bytes decode to the samples.
template <typename Direction>
void check_golden(const std::string& name, const std::vector<Direction>& samples) {
  const std::string encoded = encode_all(samples);
  if (std::getenv("SCARATWIN_UPDATE_GOLDEN")) {
    std::ofstream(golden_path(name), std::ios::binary) << encoded;
  }
  const std::string golden = read_file(golden_path(name));
  ASSERT_FALSE(golden.empty()) << "missing " << golden_path(name);
  EXPECT_EQ(encoded, golden) << name;
  std::vector<DecodeError> errors;
  EXPECT_EQ(decode_all<Direction>(golden, &errors), samples) << name;
  EXPECT_TRUE(errors.empty()) << errors.front().message;
}

TEST(ProtocolGolden, SerialToDevice) {
  check_golden("serial_to_device.txt", test::serial_to_device_samples());
}
TEST(ProtocolGolden, SerialFromDevice) {
  check_golden("serial_from_device.txt", test::serial_from_device_samples());
}
TEST(ProtocolGolden, TcpToSim) { check_golden("tcp_to_sim.txt", test::tcp_to_sim_samples()); }
TEST(ProtocolGolden, TcpFromSim) { check_golden("tcp_from_sim.txt", test::tcp_from_sim_samples()); }

TEST(ProtocolEncode, WritesWireUnits) {
  const auto jd =
      encode(JointData{17, 5000123, {0.12, deg_to_rad(12.5), deg_to_rad(-30.25), deg_to_rad(90)}},
             Framing::kTcp);
  ASSERT_TRUE(jd.ok());
  EXPECT_EQ(*jd, "JD,17,5000123,120,12.5,-30.25,90,\n");
  const auto gr = encode(SetGripper{deg_to_rad(75)}, Framing::kSerial);
  ASSERT_TRUE(gr.ok());
  EXPECT_EQ(*gr, "GR=7500=\n");
  const auto tp = encode(TrajectoryPoint{2, 0.5, {20000, 0, 0}, deg_to_rad(45), deg_to_rad(75)},
                         Framing::kSerial);
  ASSERT_TRUE(tp.ok());
  EXPECT_EQ(*tp, "TP=2=500=20000=0=0=4500=7500=\n");
  EXPECT_EQ(*encode(Stop{}, Framing::kSerial), "SP=\n");
  EXPECT_EQ(*encode(Stop{}, Framing::kTcp), "SP,\n");
  EXPECT_EQ(*encode(RealtimeCommand{Realtime::kHold}, Framing::kSerial), "#");
}

TEST(ProtocolEncode, RefusesValuesTheWireCannotCarry) {
  const auto nan = encode(JointData{1, 2, {std::nan(""), 0, 0, 0}}, Framing::kTcp);
  ASSERT_FALSE(nan.ok());
  EXPECT_EQ(nan.error().code, protocol_error_code(core::kErrBadValue));
  EXPECT_NE(nan.error().message.find("q[0]"), std::string::npos) << nan.error().message;
  const auto huge = encode(SpawnCube{CubeColor::kRed, 1e9, 0}, Framing::kTcp);
  ASSERT_FALSE(huge.ok());
  EXPECT_NE(huge.error().message.find("x_m"), std::string::npos) << huge.error().message;
  const auto text = encode(PeerHello{1, "bad name", "1", {}}, Framing::kTcp);
  ASSERT_FALSE(text.ok());
  EXPECT_EQ(text.error().code, protocol_error_code(core::kErrBadValue));
  const auto wrong_link = encode(JointData{}, Framing::kSerial);
  ASSERT_FALSE(wrong_link.ok());
  EXPECT_EQ(wrong_link.error().code, protocol_error_code(core::kErrUnknownCode));
  Image big;
  big.png.resize(core::kMaxImageBytes + 1);
  const auto image = encode(big, Framing::kTcp);
  ASSERT_FALSE(image.ok());
  EXPECT_EQ(image.error().code, protocol_error_code(core::kErrPayloadTooLarge));
  std::string out = "AK,RS,\n";
  EXPECT_FALSE(append(out, TcpToSim(JointData{1, 2, {INFINITY, 0, 0, 0}})).ok());
  EXPECT_EQ(out, "AK,RS,\n");
}

// The hello's description hash (docs/protocol.md section 11): an optional last field on both
// links and in both directions; a v1 hello (without it) still decodes, to an empty hash.
TEST(ProtocolHello, CarriesTheDescriptionHashOnBothLinks) {
  EXPECT_EQ(*encode(Hello{1, {}, {}, "c6e454cc", std::nullopt}, Framing::kSerial),
            "HI=1=c6e454cc=\n");
  EXPECT_EQ(*encode(Hello{1, {}, {}, "c6e454cc", std::nullopt}, Framing::kTcp),
            "HI,1,control,-,c6e454cc,\n");
  EXPECT_EQ(*encode(Hello{1, "observe", "tok", "c6e454cc", std::nullopt}, Framing::kTcp),
            "HI,1,observe,tok,c6e454cc,\n");
  EXPECT_EQ(*encode(PeerHello{1, "scara-uno", "0.1.0", "0badf00d"}, Framing::kSerial),
            "HI=1=scara-uno=0.1.0=0badf00d=\n");
  EXPECT_EQ(*encode(PeerHello{1, "scaratwin-sim", "0.1.0", "0badf00d"}, Framing::kTcp),
            "HI,1,scaratwin-sim,0.1.0,0badf00d,\n");

  SerialToDeviceDecoder to_device;
  auto got = to_device.feed("HI=1=c6e454cc=\nHI=1=\n");
  ASSERT_EQ(got.size(), 2u);
  EXPECT_EQ(std::get<Hello>(std::get<0>(got[0])).description, "c6e454cc");
  EXPECT_EQ(std::get<Hello>(std::get<0>(got[1])).description, "");
  TcpToSimDecoder to_sim;
  auto hi = to_sim.feed("HI,1,control,-,c6e454cc,\nHI,1,control,tok,\n");
  ASSERT_EQ(hi.size(), 2u);
  const auto& described = std::get<Hello>(std::get<0>(hi[0]));
  EXPECT_EQ(described.token, "") << "'-' stands for no token";
  EXPECT_EQ(described.description, "c6e454cc");
  EXPECT_EQ(std::get<Hello>(std::get<0>(hi[1])).token, "tok");
  EXPECT_EQ(std::get<Hello>(std::get<0>(hi[1])).description, "");
  SerialFromDeviceDecoder from_device;
  auto peer = from_device.feed("HI=1=scara-uno=0.1.0=0badf00d=\nHI=1=scara-uno=0.1.0=\n");
  ASSERT_EQ(peer.size(), 2u);
  EXPECT_EQ(std::get<PeerHello>(std::get<0>(peer[0])).description, "0badf00d");
  EXPECT_EQ(std::get<PeerHello>(std::get<0>(peer[1])).description, "");
}

// The robot a controlling hello names (docs/protocol.md section 11.3): TCP only, after the
// description hash, which it needs; 0..255.
TEST(ProtocolHello, NamesTheRobotItDrivesAfterTheDescription) {
  EXPECT_EQ(*encode(Hello{1, {}, {}, "c6e454cc", 1}, Framing::kTcp),
            "HI,1,control,-,c6e454cc,1,\n");
  EXPECT_EQ(*encode(Hello{1, {}, {}, "c6e454cc", 0}, Framing::kTcp), "HI,1,control,-,c6e454cc,0,\n")
      << "robot 0 named is not the same as no robot named (the whole simulator)";
  for (auto [hello, framing] : {std::pair{Hello{1, {}, {}, "", 1}, Framing::kTcp},
                                std::pair{Hello{1, {}, {}, "c6e454cc", 1}, Framing::kSerial},
                                std::pair{Hello{1, {}, {}, "c6e454cc", 256}, Framing::kTcp},
                                std::pair{Hello{1, {}, {}, "c6e454cc", -1}, Framing::kTcp}}) {
    const auto bad = encode(hello, framing);
    ASSERT_FALSE(bad.ok()) << hello.robot.value_or(-99);
    EXPECT_EQ(bad.error().code, protocol_error_code(core::kErrBadValue));
    EXPECT_NE(bad.error().message.find("robot"), std::string::npos) << bad.error().message;
  }
  TcpToSimDecoder to_sim;
  auto hi = to_sim.feed("HI,1,control,-,c6e454cc,3,\nHI,1,control,-,c6e454cc,\n");
  ASSERT_EQ(hi.size(), 2u);
  EXPECT_EQ(std::get<Hello>(std::get<0>(hi[0])).robot, std::optional<std::int32_t>(3));
  EXPECT_EQ(std::get<Hello>(std::get<0>(hi[1])).robot, std::nullopt);
  auto bad = to_sim.feed("HI,1,control,-,c6e454cc,256,\n");
  ASSERT_EQ(bad.size(), 1u);
  const auto* e = std::get_if<DecodeError>(&bad[0]);
  ASSERT_NE(e, nullptr);
  EXPECT_EQ(e->code, core::kErrBadValue);
  EXPECT_EQ(e->detail, 4);
  SerialToDeviceDecoder to_device;
  auto serial = to_device.feed("HI=1=c6e454cc=1=\n");
  ASSERT_EQ(serial.size(), 1u);
  ASSERT_TRUE(std::holds_alternative<DecodeError>(serial[0]))
      << "the serial link reaches one robot: its hello has no robot field";
  EXPECT_EQ(std::get<DecodeError>(serial[0]).code, core::kErrWrongFieldCount);
}

TEST(ProtocolHello, ABadDescriptionHashIsBadValueNamingTheField) {
  TcpFromSimDecoder from_sim;
  for (const char* line :
       {"HI,1,scaratwin-sim,0.1.0,C6E454CC,\n", "HI,1,scaratwin-sim,0.1.0,c6e454c,\n",
        "HI,1,scaratwin-sim,0.1.0,c6e454ccc,\n", "HI,1,scaratwin-sim,0.1.0,c6e454cg,\n"}) {
    auto got = from_sim.feed(line);
    ASSERT_EQ(got.size(), 1u) << line;
    const auto* e = std::get_if<DecodeError>(&got[0]);
    ASSERT_NE(e, nullptr) << line;
    EXPECT_EQ(e->code, core::kErrBadValue) << line;
    EXPECT_EQ(e->detail, 3) << line;
    EXPECT_NE(e->message.find("8 lower-case hex digits"), std::string::npos) << e->message;
  }
  SerialToDeviceDecoder to_device;
  auto got = to_device.feed("HI=1=xyz=\n");
  ASSERT_EQ(got.size(), 1u);
  ASSERT_TRUE(std::holds_alternative<DecodeError>(got[0]));
  EXPECT_EQ(std::get<DecodeError>(got[0]).detail, 1);
  const auto bad = encode(Hello{1, {}, {}, "C6E454CC", std::nullopt}, Framing::kSerial);
  ASSERT_FALSE(bad.ok());
  EXPECT_EQ(bad.error().code, protocol_error_code(core::kErrBadValue));
}

// Protocol v2's robot index (docs/protocol.md section 11.3): an optional last field of every
// robot-addressed TCP packet; a packet without one addresses robot 0, and robot 0's packets are
// written as version 1's.
using test::deg;
using test::mm;

TEST(ProtocolRobotIndex, RoundTripsOnEveryRobotAddressedPacket) {
  const JointVector q{mm(120), deg(12.5), deg(-30.25), deg(90)};
  const std::vector<TcpToSim> to_sim = {
      JointData{17, 5000123, q, 3},
      JointTargets{4, 100, q, 255},
      SetMode{SimMode::kSimulate, 1},
      Grasp{true, 2},
      QueryState{7},
      Stop{1},
      SetTwinPhase{TwinPhase::kControl, 9},
  };
  const std::vector<std::string> to_sim_text = {"JD,17,5000123,120,12.5,-30.25,90,3,\n",
                                                "TJ,4,100,120,12.5,-30.25,90,255,\n",
                                                "MD,simulate,1,\n",
                                                "GR,1,2,\n",
                                                "QS,7,\n",
                                                "SP,1,\n",
                                                "TW,control,9,\n"};
  for (std::size_t i = 0; i < to_sim.size(); ++i) {
    const auto text = encode(to_sim[i]);
    ASSERT_TRUE(text.ok()) << text.error().message;
    EXPECT_EQ(*text, to_sim_text[i]);
    TcpToSimDecoder d;
    const auto back = d.feed(*text);
    ASSERT_EQ(back.size(), 1u) << *text;
    ASSERT_TRUE(std::holds_alternative<TcpToSim>(back[0]))
        << std::get<DecodeError>(back[0]).message;
    EXPECT_EQ(std::get<TcpToSim>(back[0]), to_sim[i]) << *text;
  }
  SimState st;
  st.seq = 5;
  st.q = q;
  st.robot = 4;
  const std::vector<TcpFromSim> from_sim = {JointApplied{17, 5000410, 3}, GripperState{true, 3, 1},
                                            st, JointWarning{2, deg(130), 2}};
  const std::vector<std::string> from_sim_text = {"JA,17,5000410,3,\n", "GR,1,3,1,\n",
                                                  "ST,5,0,120,12.5,-30.25,90,0,-1,mirror,4,\n",
                                                  "JW,2,130,2,\n"};
  for (std::size_t i = 0; i < from_sim.size(); ++i) {
    const auto text = encode(from_sim[i]);
    ASSERT_TRUE(text.ok()) << text.error().message;
    EXPECT_EQ(*text, from_sim_text[i]);
    TcpFromSimDecoder d;
    const auto back = d.feed(*text);
    ASSERT_EQ(back.size(), 1u) << *text;
    ASSERT_TRUE(std::holds_alternative<TcpFromSim>(back[0]))
        << std::get<DecodeError>(back[0]).message;
    EXPECT_EQ(std::get<TcpFromSim>(back[0]), from_sim[i]) << *text;
  }
}

TEST(ProtocolRobotIndex, VersionOnePacketsAddressRobotZero) {
  TcpToSimDecoder to_sim;
  const auto got = to_sim.feed(
      "JD,17,5000123,120,12.5,-30.25,90,\nTJ,3,100,10,0,0,180,\nMD,mirror,\nGR,0,\nQS,\nSP,\n"
      "TW,none,\nJD,18,5000124,120,12.5,-30.25,90,0,\n");
  ASSERT_EQ(got.size(), 8u);
  for (const auto& d : got) {
    ASSERT_TRUE(std::holds_alternative<TcpToSim>(d)) << std::get<DecodeError>(d).message;
    std::visit(
        [](const auto& m) {
          if constexpr (requires { m.robot; }) {
            EXPECT_EQ(m.robot, 0);
          }
        },
        std::get<TcpToSim>(d));
  }
  TcpFromSimDecoder from_sim;
  const auto replies =
      from_sim.feed("JA,17,5000410,\nGR,1,3,\nST,1,2,120,0,0,0,0,-1,mirror,\nJW,1,125,\n");
  ASSERT_EQ(replies.size(), 4u);
  for (const auto& d : replies) {
    ASSERT_TRUE(std::holds_alternative<TcpFromSim>(d)) << std::get<DecodeError>(d).message;
    std::visit(
        [](const auto& m) {
          if constexpr (requires { m.robot; }) {
            EXPECT_EQ(m.robot, 0);
          }
        },
        std::get<TcpFromSim>(d));
  }
  // robot 0 is written as version 1 writes it
  EXPECT_EQ(*encode(TcpToSim(QueryState{0})), "QS,\n");
  EXPECT_EQ(*encode(TcpToSim(JointData{17, 5000123, {mm(120), 0, 0, 0}, 0})),
            "JD,17,5000123,120,0,0,0,\n");
}

TEST(ProtocolRobotIndex, AnIndexOutOfRangeIsBadValueAndSerialHasNone) {
  TcpToSimDecoder to_sim;
  const auto got = to_sim.feed("QS,256,\nSP,-1,\nJD,1,2,120,0,0,0,1.5,\nGR,1,70000,\n");
  ASSERT_EQ(got.size(), 4u);
  const std::vector<std::pair<std::int32_t, std::int32_t>> want = {{core::kErrBadValue, 0},
                                                                   {core::kErrBadValue, 0},
                                                                   {core::kErrBadNumber, 6},
                                                                   {core::kErrBadValue, 1}};
  for (std::size_t i = 0; i < got.size(); ++i) {
    ASSERT_TRUE(std::holds_alternative<DecodeError>(got[i])) << i;
    EXPECT_EQ(std::get<DecodeError>(got[i]).code, want[i].first) << i;
    EXPECT_EQ(std::get<DecodeError>(got[i]).detail, want[i].second) << i;
  }
  const auto serial = encode(SerialToDevice(QueryState{1}));
  ASSERT_FALSE(serial.ok());
  EXPECT_NE(serial.error().message.find("robot"), std::string::npos) << serial.error().message;
  EXPECT_FALSE(encode(TcpToSim(Stop{256})).ok());
  SerialToDeviceDecoder to_device;
  const auto qs = to_device.feed("QS=1=\n");
  ASSERT_EQ(qs.size(), 1u);
  ASSERT_TRUE(std::holds_alternative<DecodeError>(qs[0]));
  EXPECT_EQ(std::get<DecodeError>(qs[0]).code, core::kErrWrongFieldCount);
}

TEST(ProtocolDecode, ConvertsToSi) {
  TcpToSimDecoder d;
  const auto items = d.feed("JD,17,5000123,120,12.5,-30.25,90,\nSC,blue,-0.5,187,\n");
  ASSERT_EQ(items.size(), 2u);
  const auto& jd = std::get<JointData>(std::get<0>(items[0]));
  EXPECT_EQ(jd.seq, 17);
  EXPECT_EQ(jd.t_us, 5000123u);
  EXPECT_DOUBLE_EQ(jd.q[0], 0.12);
  EXPECT_DOUBLE_EQ(jd.q[1], deg_to_rad(12.5));
  EXPECT_DOUBLE_EQ(jd.q[2], deg_to_rad(-30.25));
  const auto& sc = std::get<SpawnCube>(std::get<0>(items[1]));
  EXPECT_EQ(sc.color, CubeColor::kBlue);
  EXPECT_DOUBLE_EQ(sc.x_m, -0.0005);
  EXPECT_DOUBLE_EQ(sc.y_m, 0.187);

  SerialFromDeviceDecoder s;
  const auto st = s.feed("ST=3=99=1=-2=3=4500=-100=5=8=\n");
  ASSERT_EQ(st.size(), 1u);
  const auto& state = std::get<DeviceState>(std::get<0>(st[0]));
  EXPECT_EQ(state.steps, (MotorSteps{1, -2, 3}));
  EXPECT_DOUBLE_EQ(state.wrist_rad, deg_to_rad(45));
  EXPECT_DOUBLE_EQ(state.grip_rad, deg_to_rad(-1));
  EXPECT_EQ(state.flags, 5u);
  EXPECT_EQ(state.queue_free, 8);
}

TEST(ProtocolDecode, DecimalsAreCorrectlyRoundedOnBothPaths) {
  // small values take the millionths fast path, large ones the generic one; both must give
  // mantissa / 10^(fraction digits + 3) in one rounding.
  struct Case {
    const char* text;
    double mantissa;
    int divisor_exp;
  };
  const Case cases[] = {{"2147.483647", 2147483647.0, 9},
                        {"2147.483648", 2147483648.0, 9},
                        {"-2147.483648", -2147483648.0, 9},
                        {"0.1", 1.0, 4},
                        {"-0.000001", -1.0, 9},
                        {"999999999.999999", 999999999999999.0, 9},
                        {"123456789", 123456789.0, 3},
                        {"0007.5", 75.0, 4}};
  for (const Case& c : cases) {
    TcpToSimDecoder d;
    const auto items = d.feed(std::string("SC,red,") + c.text + ",0,\n");
    ASSERT_EQ(items.size(), 1u);
    ASSERT_EQ(items[0].index(), 0u) << c.text;
    EXPECT_EQ(std::get<SpawnCube>(std::get<0>(items[0])).x_m,
              c.mantissa / std::pow(10.0, c.divisor_exp))
        << c.text;
  }
}

TEST(ProtocolDecode, ImageArrivesWholeWhateverTheChunking) {
  const std::string png("\x89PNG\r\n\x1a\n\0\nIM,3,\n", 17);
  const std::string stream = "IM,17,\n" + png + "GR,1,3,\nIM,0,\n";
  for (std::size_t cut = 0; cut <= stream.size(); ++cut) {
    TcpFromSimDecoder d;
    auto items = d.feed(stream.substr(0, cut));
    auto rest = d.feed(stream.substr(cut));
    items.insert(items.end(), rest.begin(), rest.end());
    ASSERT_EQ(items.size(), 3u) << cut;
    const auto& image = std::get<Image>(std::get<0>(items[0]));
    EXPECT_EQ(std::string(image.png.begin(), image.png.end()), png);
    EXPECT_EQ(std::get<GripperState>(std::get<0>(items[1])), (GripperState{true, 3}));
    EXPECT_TRUE(std::get<Image>(std::get<0>(items[2])).png.empty());
  }
}

TEST(ProtocolDecode, RealtimeBytesBecomeCommands) {
  SerialToDeviceDecoder d;
  const auto items = d.feed("TB=2!=\n~");
  ASSERT_EQ(items.size(), 3u);
  EXPECT_EQ(std::get<RealtimeCommand>(std::get<0>(items[0])).command, Realtime::kStop);
  EXPECT_EQ(std::get<TrajectoryBegin>(std::get<0>(items[1])).points, 2);
  EXPECT_EQ(std::get<RealtimeCommand>(std::get<0>(items[2])).command, Realtime::kResume);
}

// Random messages, encoded back to back and fed in random chunks, decode to themselves.
template <typename Direction>
void check_random_chunking(const std::vector<Direction>& samples, unsigned seed) {
  std::mt19937 rng(seed);
  const auto messages = test::random_stream(samples, rng, 400);
  const std::string bytes = encode_all(messages);
  for (int run = 0; run < 20; ++run) {
    StreamDecoder<Direction> d;
    std::vector<Direction> got;
    std::uniform_int_distribution<std::size_t> chunk(1, 1 + static_cast<std::size_t>(run) * 13);
    for (std::size_t at = 0; at < bytes.size();) {
      const std::size_t n = std::min(chunk(rng), bytes.size() - at);
      d.feed(std::string_view(bytes).substr(at, n), [&](Decoded<Direction>&& item) {
        ASSERT_EQ(item.index(), 0u) << std::get<1>(item).message;
        got.push_back(std::move(std::get<0>(item)));
      });
      at += n;
    }
    ASSERT_EQ(got, messages) << "run " << run;
  }
}

TEST(ProtocolChunking, SerialToDevice) {
  check_random_chunking(test::serial_to_device_samples(), 11);
}
TEST(ProtocolChunking, SerialFromDevice) {
  check_random_chunking(test::serial_from_device_samples(), 12);
}
TEST(ProtocolChunking, TcpToSim) { check_random_chunking(test::tcp_to_sim_samples(), 13); }
TEST(ProtocolChunking, TcpFromSim) { check_random_chunking(test::tcp_from_sim_samples(), 14); }

}  // namespace
}  // namespace scaratwin::protocol
