// Sequence-gap counting and the lost-packet counter the message layer feeds.
#include <gtest/gtest.h>

#include "eventually.hpp"

#include "scaratwin/transport/link.hpp"
#include "scaratwin/transport/tcp.hpp"

namespace scaratwin::transport {
namespace {

TEST(SequenceTracker, CountsGapsAcrossTheWrap) {
  SequenceTracker t;
  EXPECT_EQ(t.observe(65530), 0u);  // first packet: nothing known before it
  EXPECT_EQ(t.observe(65531), 0u);
  EXPECT_EQ(t.observe(65534), 2u);  // 65532, 65533 lost
  EXPECT_EQ(t.observe(1), 2u);      // 65535, 0 lost
  EXPECT_EQ(t.observe(2), 0u);
  EXPECT_EQ(t.lost(), 4u);
  EXPECT_EQ(t.backwards(), 0u);
}

TEST(SequenceTracker, StepBackIsNotLossAndResyncs) {
  SequenceTracker t;
  t.observe(100);
  t.observe(101);
  EXPECT_EQ(t.observe(101), 0u);  // duplicate
  EXPECT_EQ(t.observe(5), 0u);    // peer restarted
  EXPECT_EQ(t.observe(6), 0u);
  EXPECT_EQ(t.observe(9), 2u);
  EXPECT_EQ(t.lost(), 2u);
  EXPECT_EQ(t.backwards(), 2u);
  t.reset();
  EXPECT_EQ(t.observe(1000), 0u);
}

// A peer sends numbered state lines with holes; the receiving side tracks them and feeds the
// link's lost-packet counter, as the message layer does.
TEST(LinkCounters, LostPacketsFromSequenceGapsOverARealLink) {
  TcpServerOptions so;
  so.port = 0;
  auto server = TcpServer::create(so);
  ASSERT_TRUE(server);
  TcpClientOptions co;
  co.port = (*server)->port();
  auto client = TcpClient::create(co);
  ASSERT_TRUE(client);
  ASSERT_TRUE((*client)->wait_connected(Duration{5000}));
  ASSERT_TRUE((*server)->wait_connected(Duration{5000}));

  std::string burst;
  int sent = 0;
  for (int seq = 65500; seq < 65500 + 100; ++seq) {
    if (seq % 10 == 3) continue;  // every tenth is "lost"
    burst += "ST," + std::to_string(seq % 65536) + ",0,0,0,0,0,\n";
    ++sent;
  }
  ASSERT_TRUE((*server)->send(burst));
  SequenceTracker tracker;
  for (int i = 0; i < sent; ++i) {
    auto p = (*client)->receive(Duration{5000});
    ASSERT_TRUE(p);
    const auto seq = static_cast<std::uint16_t>(std::stoi(p->line.substr(3)));
    (*client)->add_lost_packets(tracker.observe(seq));
  }
  const auto c = (*client)->counters();
  EXPECT_EQ(c.packets_in, static_cast<std::uint64_t>(sent));
  EXPECT_TRUE(eventually([&] { return (*server)->counters().packets_out >= 90u; }));
  EXPECT_EQ((*server)->counters().packets_out, static_cast<std::uint64_t>(sent));
  // 65503, 65513, ... 65593: ten numbers end in 3; the first (65503) lies after the first
  // received packet, so all ten are gaps
  EXPECT_EQ(c.lost_packets, 10u);
  (*client)->add_error();
  EXPECT_EQ((*client)->counters().errors, 1u);
}

TEST(LinkCounters, TransmitQueueIsBounded) {
  TcpServerOptions so;
  so.port = 0;
  so.link.max_tx_queue_bytes = 1000;
  auto server = TcpServer::create(so);
  ASSERT_TRUE(server);
  TcpClientOptions co;
  co.port = (*server)->port();
  auto client = TcpClient::create(co);
  ASSERT_TRUE(client);
  ASSERT_TRUE((*server)->wait_connected(Duration{5000}));
  auto r = (*server)->send(std::string(1001, 'x'));
  ASSERT_FALSE(r);
  EXPECT_EQ(r.error().code, static_cast<int>(TransportError::kBufferFull));
  EXPECT_NE(r.error().message.find("1000"), std::string::npos);
}

}  // namespace
}  // namespace scaratwin::transport
