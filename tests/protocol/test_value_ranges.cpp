// Every value range a receiver checks (docs/protocol.md sections 7 and 8, and section 6's
// "bad value": ER 11 with the field's index), at both ends and one past each: the bounds are
// written out here by hand from the docs, independently of the packet structs' rows that the
// decoder runs on.
#include <gtest/gtest.h>

#include <cstdint>
#include <string>
#include <vector>

#include "scaratwin/protocol/codec.hpp"

namespace scaratwin::protocol {
namespace {

struct Bound {
  const char* line;  // a valid packet with "{}" where the checked field goes
  int field;         // the field's index, the ER's detail
  std::int64_t lo;
  std::int64_t hi;
};

std::string with(const char* line, std::int64_t v) {
  std::string s = line;
  return s.replace(s.find("{}"), 2, std::to_string(v));
}

// Accepted at lo and hi, refused as a bad value of `field` one past each (unless one past is
// not an i32 at all, which is a bad number).
template <typename Direction>
void check_bounds(const std::vector<Bound>& bounds) {
  for (const Bound& b : bounds) {
    for (const std::int64_t v : {b.lo, b.hi}) {
      const std::string line = with(b.line, v);
      SCOPED_TRACE(line);
      StreamDecoder<Direction> d;
      const auto items = d.feed(line);
      ASSERT_EQ(items.size(), 1u);
      EXPECT_EQ(items[0].index(), 0u) << std::get<1>(items[0]).message;
    }
    for (const std::int64_t v : {b.lo - 1, b.hi + 1}) {
      if (v < INT32_MIN || v > INT32_MAX) continue;
      const std::string line = with(b.line, v);
      SCOPED_TRACE(line);
      StreamDecoder<Direction> d;
      const auto items = d.feed(line);
      ASSERT_EQ(items.size(), 1u);
      ASSERT_EQ(items[0].index(), 1u) << "accepted";
      const DecodeError& e = std::get<1>(items[0]);
      EXPECT_EQ(e.code, core::kErrBadValue) << e.message;
      EXPECT_EQ(e.detail, b.field) << e.message;
      EXPECT_NE(e.message.find(std::to_string(b.lo) + ".." + std::to_string(b.hi)),
                std::string::npos)
          << e.message;
    }
  }
}

TEST(ProtocolRanges, SerialHostToDevice) {
  check_bounds<SerialToDevice>({
      {"SR={}=\n", 0, 0, 1000},
      {"TB={}=\n", 0, 1, 65535},
      {"TP={}=10=0=0=0=0=\n", 0, 0, 65534},
      {"TP=0={}=0=0=0=0=\n", 1, 1, 65535},
      {"TP=0=10=0=0=0={}=\n", 5, 0, 18000},
      {"TP=0=10=0=0=0=0={}=\n", 6, 0, 18000},
      {"GR={}=\n", 0, 0, 18000},
      {"JG={}=5=\n", 0, 0, 3},
      {"CF={}=\n", 0, 1, 11},
  });
}

TEST(ProtocolRanges, SerialDeviceToHost) {
  check_bounds<SerialFromDevice>({
      {"ST={}=1=0=0=0=0=0=0=15=\n", 0, 0, 65535},
      {"ST=0=1=0=0=0=0=0={}=15=\n", 7, 0, 2147483647},
      {"ST=0=1=0=0=0=0=0=0={}=\n", 8, 0, 65535},
      {"ER={}=\n", 0, 1, 255},
      {"EV={}=\n", 0, 1, 12},
  });
}

TEST(ProtocolRanges, TcpHubToSim) {
  check_bounds<TcpToSim>({
      {"JD,{},1,0,0,0,0,\n", 0, 0, 65535},
      {"JD,0,1,0,0,0,0,{},\n", 6, 0, 255},
      {"TJ,{},1,0,0,0,0,\n", 0, 0, 65535},
      {"TJ,0,1,0,0,0,0,{},\n", 6, 0, 255},
      {"MD,mirror,{},\n", 1, 0, 255},
      {"TW,control,{},\n", 1, 0, 255},
      {"GR,{},\n", 0, 0, 1},
      {"GR,1,{},\n", 1, 0, 255},
      {"CS,{},480,\n", 0, 1, 8192},
      {"CS,640,{},\n", 1, 1, 8192},
      {"QS,{},\n", 0, 0, 255},
      {"SP,{},\n", 0, 0, 255},
  });
}

TEST(ProtocolRanges, TcpSimToHub) {
  check_bounds<TcpFromSim>({
      {"JA,{},1,\n", 0, 0, 65535},
      {"JA,0,1,{},\n", 2, 0, 255},
      {"GR,{},-1,\n", 0, 0, 1},
      {"GR,1,{},\n", 1, -1, 2147483647},
      {"GR,1,-1,{},\n", 2, 0, 255},
      {"ST,{},1,0,0,0,0,0,-1,mirror,\n", 0, 0, 65535},
      {"ST,0,1,0,0,0,0,{},-1,mirror,\n", 6, 0, 1},
      {"ST,0,1,0,0,0,0,0,{},mirror,\n", 7, -1, 2147483647},
      {"ST,0,1,0,0,0,0,0,-1,mirror,{},\n", 9, 0, 255},
      {"JW,{},0,\n", 0, 1, 4},
      {"JW,1,0,{},\n", 2, 0, 255},
      {"ER,{},\n", 0, 1, 255},
  });
}

}  // namespace
}  // namespace scaratwin::protocol
