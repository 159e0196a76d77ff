#include "scaratwin/transport/line_splitter.hpp"

#include <gtest/gtest.h>

#include <random>

namespace scaratwin::transport {
namespace {

std::vector<Frame> split(LineSplitter& s, std::string_view bytes) {
  std::vector<Frame> out;
  s.feed(bytes, [&](Frame&& f) { out.push_back(std::move(f)); });
  return out;
}

SplitterOptions tcp_options() {
  SplitterOptions o;
  o.max_line_bytes = 511;
  o.binary_prefix = "IM,";
  return o;
}

TEST(LineSplitter, SplitsMixedPacketsOfOneWrite) {
  LineSplitter s(tcp_options());
  auto frames = split(s, "JD,17,5000123,120,12.5,-30.25,90,\nGR,1,\r\nCS,320,240,\n");
  ASSERT_EQ(frames.size(), 3u);
  EXPECT_EQ(frames[0].line, "JD,17,5000123,120,12.5,-30.25,90,");
  EXPECT_EQ(frames[1].line, "GR,1,");
  EXPECT_EQ(frames[2].line, "CS,320,240,");
  for (const auto& f : frames) EXPECT_EQ(f.kind, FrameKind::kLine);
  EXPECT_FALSE(s.mid_frame());
}

TEST(LineSplitter, SkipsEmptyLines) {
  LineSplitter s(tcp_options());
  auto frames = split(s, "\n\r\nPI,\n\n");
  ASSERT_EQ(frames.size(), 1u);
  EXPECT_EQ(frames[0].line, "PI,");
}

// A stream of lines and binary payloads (payloads full of '\n' and '\r') cut at random
// places gives the same frames as the whole stream at once.
TEST(LineSplitter, AnyChunkingGivesTheSameFrames) {
  std::mt19937 rng(12345);
  std::string stream;
  std::vector<std::vector<std::uint8_t>> payloads;
  for (int i = 0; i < 40; ++i) {
    stream += "JD," + std::to_string(i) + ",1,2,3,4,5,\n";
    if (i % 5 == 0) {
      std::vector<std::uint8_t> p(static_cast<std::size_t>(rng() % 3000));
      for (auto& b : p) b = static_cast<std::uint8_t>(rng() % 4 == 0 ? '\n' : rng());
      stream += "IM," + std::to_string(p.size()) + ",\n";
      stream.append(reinterpret_cast<const char*>(p.data()), p.size());
      payloads.push_back(p);
    }
  }
  LineSplitter whole(tcp_options());
  const auto expected = split(whole, stream);
  ASSERT_EQ(expected.size(), 40u + payloads.size());
  std::size_t bin = 0;
  for (const auto& f : expected) {
    if (f.kind == FrameKind::kBinary) {
      EXPECT_EQ(f.payload, payloads[bin++]);
    }
  }
  EXPECT_EQ(bin, payloads.size());

  for (int trial = 0; trial < 50; ++trial) {
    LineSplitter s(tcp_options());
    std::vector<Frame> got;
    std::size_t pos = 0;
    while (pos < stream.size()) {
      std::size_t n = std::min<std::size_t>(stream.size() - pos, 1 + rng() % 700);
      if (trial == 0) n = 1;  // byte by byte
      s.feed(std::string_view(stream).substr(pos, n), [&](Frame&& f) { got.push_back(f); });
      pos += n;
    }
    ASSERT_EQ(got.size(), expected.size()) << "trial " << trial;
    for (std::size_t i = 0; i < got.size(); ++i) {
      EXPECT_EQ(got[i].kind, expected[i].kind);
      EXPECT_EQ(got[i].line, expected[i].line);
      EXPECT_EQ(got[i].payload, expected[i].payload);
    }
  }
}

TEST(LineSplitter, OverlongLineIsReportedOnceAtTheLimitAndResyncs) {
  SplitterOptions o;
  o.max_line_bytes = 95;
  LineSplitter s(o);
  std::string longline(300, 'A');
  // reported as soon as the limit is passed, before its newline comes (if it ever does)
  auto frames = split(s, longline.substr(0, 95));
  EXPECT_TRUE(frames.empty()) << "at the limit";
  frames = split(s, longline.substr(95, 5));
  ASSERT_EQ(frames.size(), 1u);
  EXPECT_EQ(frames[0].kind, FrameKind::kOverlong);
  EXPECT_EQ(frames[0].line, std::string(95, 'A'));
  // the rest of it is skipped, the next line comes through
  frames = split(s, longline.substr(100) + "\nST=1=2=\n");
  ASSERT_EQ(frames.size(), 1u);
  EXPECT_EQ(frames[0].kind, FrameKind::kLine);
  EXPECT_EQ(frames[0].line, "ST=1=2=");
  // a line at the limit whose '\r' ends a chunk waits for the next byte
  frames = split(s, std::string(95, 'C') + "\r");
  EXPECT_TRUE(frames.empty());
  frames = split(s, "\n");
  ASSERT_EQ(frames.size(), 1u);
  EXPECT_EQ(frames[0].kind, FrameKind::kLine);
  frames = split(s, std::string(95, 'C') + "\r");
  frames = split(s, "X\n");
  ASSERT_EQ(frames.size(), 1u);
  EXPECT_EQ(frames[0].kind, FrameKind::kOverlong);
}

TEST(LineSplitter, LineAtTheLimitIsAcceptedWithOrWithoutCarriageReturn) {
  SplitterOptions o;
  o.max_line_bytes = 95;
  LineSplitter s(o);
  const std::string line(95, 'B');
  auto frames = split(s, line + "\n" + line + "\r\n" + line + "B\n");
  ASSERT_EQ(frames.size(), 3u);
  EXPECT_EQ(frames[0].kind, FrameKind::kLine);
  EXPECT_EQ(frames[1].kind, FrameKind::kLine);
  EXPECT_EQ(frames[1].line, line);
  EXPECT_EQ(frames[2].kind, FrameKind::kOverlong);
}

TEST(LineSplitter, BinaryPayloadIsHandedThroughIntact) {
  LineSplitter s(tcp_options());
  std::string payload = "\x89PNG\r\n\x1a\n";
  payload += std::string("\0\n\r\n,IM,3,\n", 12);
  auto frames = split(s, "IM," + std::to_string(payload.size()) + ",\n" + payload + "AK,RS,\n");
  ASSERT_EQ(frames.size(), 2u);
  EXPECT_EQ(frames[0].kind, FrameKind::kBinary);
  EXPECT_EQ(frames[0].line, "IM," + std::to_string(payload.size()) + ",");
  EXPECT_EQ(std::string(frames[0].payload.begin(), frames[0].payload.end()), payload);
  EXPECT_EQ(frames[1].line, "AK,RS,");
}

TEST(LineSplitter, EmptyPayloadIsAFrame) {
  LineSplitter s(tcp_options());
  auto frames = split(s, "IM,0,\nAK,CS,\n");
  ASSERT_EQ(frames.size(), 2u);
  EXPECT_EQ(frames[0].kind, FrameKind::kBinary);
  EXPECT_TRUE(frames[0].payload.empty());
  EXPECT_EQ(frames[1].line, "AK,CS,");
}

TEST(LineSplitter, OversizePayloadIsSkippedExactly) {
  SplitterOptions o = tcp_options();
  o.max_payload_bytes = 10;
  LineSplitter s(o);
  auto frames = split(s, "IM,11,\nAAAA\nAAAAA\nPI,\n");  // 11 bytes skipped
  ASSERT_EQ(frames.size(), 2u);
  EXPECT_EQ(frames[0].kind, FrameKind::kOversize);
  EXPECT_EQ(frames[0].line, "IM,11,");
  EXPECT_TRUE(frames[0].payload.empty());
  EXPECT_EQ(frames[1].line, "PI,");
}

TEST(LineSplitter, MalformedHeadersAreOrdinaryLines) {
  LineSplitter s(tcp_options());
  auto frames =
      split(s, "IM,-5,\nIM,x,\nIM,,\nIM,5\nIM,5,6,\nIM,99999999999,\nIM,2147483648,\nPI,\n");
  ASSERT_EQ(frames.size(), 8u);
  for (const auto& f : frames) EXPECT_EQ(f.kind, FrameKind::kLine) << f.line;
}

TEST(LineSplitter, SerialLinkHasNoBinaryFraming) {
  SplitterOptions o;
  o.max_line_bytes = 95;
  LineSplitter s(o);
  auto frames = split(s, "IM,3,\nabc\n");
  ASSERT_EQ(frames.size(), 2u);
  EXPECT_EQ(frames[0].kind, FrameKind::kLine);
  EXPECT_EQ(frames[1].line, "abc");
}

TEST(LineSplitter, ResetDropsAPartialFrame) {
  LineSplitter s(tcp_options());
  EXPECT_TRUE(split(s, "JD,1,2").empty());
  EXPECT_TRUE(s.mid_frame());
  s.reset();
  EXPECT_FALSE(s.mid_frame());
  auto frames = split(s, "PI,\n");
  ASSERT_EQ(frames.size(), 1u);
  EXPECT_EQ(frames[0].line, "PI,");
}

}  // namespace
}  // namespace scaratwin::transport
