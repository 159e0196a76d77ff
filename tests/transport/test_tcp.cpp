// TCP links against each other and against plain POSIX sockets.
#include <utility>  // before Boost.Asio (Boost 1.74 misses it)

#include "scaratwin/transport/tcp.hpp"

#include <arpa/inet.h>
#include <gtest/gtest.h>

#include <boost/asio/io_context.hpp>
#include <boost/asio/post.hpp>
#include <future>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <mutex>
#include <random>
#include <thread>

#include "eventually.hpp"
#include "scaratwin/transport/io_thread.hpp"

namespace scaratwin::transport {
namespace {

using namespace std::chrono_literals;

constexpr Duration kWait{5000};  // generous: CI machines are slow under sanitizers

TcpServerOptions ephemeral_server() {
  TcpServerOptions o;
  o.port = 0;
  return o;
}

TcpClientOptions client_for(std::uint16_t port) {
  TcpClientOptions o;
  o.port = port;
  o.link.reconnect_min = Duration{20};
  o.link.reconnect_max = Duration{100};
  return o;
}

std::string str(const RxPacket& p) { return p.line; }

// A blocking socket connected to 127.0.0.1:port.
int raw_connect(std::uint16_t port) {
  int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_port = htons(port);
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  if (::connect(fd, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0) {
    ::close(fd);
    return -1;
  }
  return fd;
}

void write_all(int fd, std::string_view bytes) {
  while (!bytes.empty()) {
    ssize_t n = ::write(fd, bytes.data(), bytes.size());
    ASSERT_GT(n, 0);
    bytes.remove_prefix(static_cast<std::size_t>(n));
  }
}

std::string read_line(int fd) {
  std::string line;
  char c = 0;
  while (::read(fd, &c, 1) == 1 && c != '\n') line.push_back(c);
  return line;
}

TEST(Tcp, ClientAndServerRoundTrip) {
  auto io = IoThread::create();
  auto server = TcpServer::create(ephemeral_server(), io);
  ASSERT_TRUE(server) << server.error().message;
  auto client = TcpClient::create(client_for((*server)->port()), io);
  ASSERT_TRUE(client);
  TcpServer& s = **server;
  TcpClient& c = **client;
  ASSERT_TRUE(c.wait_connected(kWait));
  ASSERT_TRUE(s.wait_connected(kWait));

  const std::int64_t before_us = steady_now_us();
  ASSERT_TRUE(c.send("JD,17,5000123,120,12.5,-30.25,90,\nGR,1,\nCS,320,240,\n"));
  std::vector<std::string> got;
  for (int i = 0; i < 3; ++i) {
    auto p = s.receive(kWait);
    ASSERT_TRUE(p) << p.error().message;
    EXPECT_GE(p->steady_us, before_us);
    EXPECT_GT(p->system_us, 1'600'000'000'000'000);  // after 2020
    EXPECT_EQ(p->connection, 1u);
    got.push_back(str(*p));
  }
  EXPECT_EQ(
      got, (std::vector<std::string>{"JD,17,5000123,120,12.5,-30.25,90,", "GR,1,", "CS,320,240,"}));

  ASSERT_TRUE(s.send("JA,17,5000410,\n"));
  auto reply = c.receive(kWait);
  ASSERT_TRUE(reply);
  EXPECT_EQ(reply->line, "JA,17,5000410,");

  EXPECT_TRUE(eventually([&] { return s.counters().packets_out == 1u; }));
  auto cc = c.counters();
  auto sc = s.counters();
  EXPECT_EQ(cc.packets_out, 3u);
  EXPECT_EQ(sc.packets_in, 3u);
  EXPECT_EQ(sc.packets_out, 1u);
  EXPECT_EQ(cc.packets_in, 1u);
  EXPECT_EQ(cc.bytes_out, sc.bytes_in);
  EXPECT_EQ(cc.errors, 0u);
  EXPECT_EQ(cc.connects, 1u);
  EXPECT_EQ(cc.reconnects, 0u);
}

TEST(Tcp, ImagePayloadArrivesIntact) {
  auto io = IoThread::create();
  auto server = TcpServer::create(ephemeral_server(), io);
  ASSERT_TRUE(server);
  auto client = TcpClient::create(client_for((*server)->port()), io);
  ASSERT_TRUE(client);
  ASSERT_TRUE((*client)->wait_connected(kWait));
  ASSERT_TRUE((*server)->wait_connected(kWait));

  std::mt19937 rng(7);
  std::vector<std::uint8_t> png(3u << 20);  // 3 MiB: many reads
  for (auto& b : png) b = static_cast<std::uint8_t>(rng());
  png[0] = 0x89;
  png[1] = '\n';
  ASSERT_TRUE((*server)->send_binary("IM," + std::to_string(png.size()) + ",", png));
  ASSERT_TRUE((*server)->send("AK,CS,\n"));
  auto p = (*client)->receive(kWait);
  ASSERT_TRUE(p) << p.error().message;
  EXPECT_EQ(p->kind, FrameKind::kBinary);
  EXPECT_EQ(p->line, "IM," + std::to_string(png.size()) + ",");
  EXPECT_TRUE(p->payload == png);
  auto ak = (*client)->receive(kWait);
  ASSERT_TRUE(ak);
  EXPECT_EQ(ak->line, "AK,CS,");
  EXPECT_TRUE(eventually([&] { return (*server)->counters().packets_out == 2u; }));
  EXPECT_EQ((*client)->counters().packets_in, 2u);
}

// The splitter must not depend on how the peer cuts its writes: a plain socket writes one
// byte at a time.
TEST(Tcp, ServerReassemblesBytewiseWritesOfAPlainSocket) {
  auto server = TcpServer::create(ephemeral_server());
  ASSERT_TRUE(server);
  int fd = raw_connect((*server)->port());
  ASSERT_GE(fd, 0);
  ASSERT_TRUE((*server)->wait_connected(kWait));
  const std::string bytes = "SC,red,150,20.5,\nRS,\nOP,\n";
  for (char ch : bytes) {
    write_all(fd, std::string_view(&ch, 1));
    std::this_thread::sleep_for(200us);
  }
  for (const char* want : {"SC,red,150,20.5,", "RS,", "OP,"}) {
    auto p = (*server)->receive(kWait);
    ASSERT_TRUE(p);
    EXPECT_EQ(p->line, want);
  }
  ASSERT_TRUE((*server)->send("AK,RS,\n"));
  EXPECT_EQ(read_line(fd), "AK,RS,");
  ::close(fd);
}

// The last reference to an io thread dropped by a handler running on it (a link's last
// reference held by a completing handler): it cannot join itself; before, std::thread::join
// threw (EDEADLK) and the process ended in std::terminate (Tcp.IdleAndWriteTimeoutsDrop...
// under ThreadSanitizer). The handler waits until the test has let go of its own reference.
TEST(IoThread, LastReferenceDroppedOnItsOwnThreadDoesNotEndTheProcess) {
  auto io = IoThread::create("io-self");
  std::promise<void> released;
  auto go = released.get_future().share();
  std::promise<void> ran;
  auto done = ran.get_future();
  boost::asio::post(io->context(), [keep = io, go, &ran]() mutable {
    go.wait();
    ran.set_value();
    keep.reset();  // the last reference: ~IoThread on its own thread
  });
  io.reset();
  released.set_value();
  ASSERT_EQ(done.wait_for(5s), std::future_status::ready);
  std::this_thread::sleep_for(100ms);  // the helper joins and frees it
}

TEST(Tcp, PacketHandlerRunsOnTheIoThreadAndCanReply) {
  auto io = IoThread::create();
  auto server = TcpServer::create(ephemeral_server(), io);
  ASSERT_TRUE(server);
  TcpServer* s = server->get();
  std::atomic<bool> on_io{true};
  s->set_packet_handler([s, &io, &on_io](RxPacket&& p) {
    if (!io->in_io_thread()) on_io = false;
    (void)s->send("echo:" + p.line + "\n");
  });
  auto client = TcpClient::create(client_for(s->port()), io);
  ASSERT_TRUE(client);
  ASSERT_TRUE((*client)->wait_connected(kWait));
  for (int i = 0; i < 100; ++i) ASSERT_TRUE((*client)->send("PI," + std::to_string(i) + ",\n"));
  for (int i = 0; i < 100; ++i) {
    auto p = (*client)->receive(kWait);
    ASSERT_TRUE(p);
    EXPECT_EQ(p->line, "echo:PI," + std::to_string(i) + ",");
  }
  EXPECT_TRUE(on_io);
}

TEST(Tcp, ClientReconnectsAfterTheServerRestarts) {
  auto server = TcpServer::create(ephemeral_server());
  ASSERT_TRUE(server);
  const std::uint16_t port = (*server)->port();
  std::mutex m;  // declared before the client: its handler runs until the client is closed
  std::vector<LinkState> states;
  auto client = TcpClient::create(client_for(port));
  ASSERT_TRUE(client);
  TcpClient& c = **client;
  c.set_state_handler([&](LinkState st) {
    std::lock_guard lock(m);
    states.push_back(st);
  });
  ASSERT_TRUE(c.wait_connected(kWait));
  ASSERT_TRUE(c.send("HI,1,\n"));
  ASSERT_TRUE((*server)->receive(kWait));

  server.value().reset();  // the simulator goes away
  const auto t0 = std::chrono::steady_clock::now();
  while (c.connected() && std::chrono::steady_clock::now() - t0 < kWait) {
    std::this_thread::sleep_for(1ms);
  }
  EXPECT_FALSE(c.connected());
  auto refused = c.send("HI,1,\n");
  ASSERT_FALSE(refused);
  EXPECT_EQ(refused.error().code, static_cast<int>(TransportError::kNotConnected));
  std::this_thread::sleep_for(150ms);  // a few failed attempts while nobody listens

  TcpServerOptions o = ephemeral_server();
  o.port = port;
  auto again = TcpServer::create(o);
  ASSERT_TRUE(again) << again.error().message;
  ASSERT_TRUE(c.wait_connected(kWait));
  ASSERT_TRUE(c.send("HI,1,\n"));
  auto p = (*again)->receive(kWait);
  ASSERT_TRUE(p);
  EXPECT_EQ(p->line, "HI,1,");
  EXPECT_EQ(p->connection, 1u);  // the new server's first peer
  ASSERT_TRUE((*again)->send("HI,1,scaratwin-sim,0.1.0,\n"));
  auto hello = c.receive(kWait);
  ASSERT_TRUE(hello);
  EXPECT_EQ(hello->connection, 2u);  // the client's second connection
  auto cc = c.counters();
  EXPECT_EQ(cc.connects, 2u);
  EXPECT_EQ(cc.reconnects, 1u);
  EXPECT_EQ(cc.disconnects, 1u);
  std::lock_guard lock(m);
  ASSERT_GE(states.size(), 3u);
  EXPECT_EQ(states.back(), LinkState::kConnected);
  EXPECT_NE(std::find(states.begin(), states.end(), LinkState::kDisconnected), states.end());
}

TEST(Tcp, NewPeerReplacesTheCurrentOne) {
  auto server = TcpServer::create(ephemeral_server());
  ASSERT_TRUE(server);
  int first = raw_connect((*server)->port());
  ASSERT_GE(first, 0);
  write_all(first, "PI,1,\n");
  auto p1 = (*server)->receive(kWait);
  ASSERT_TRUE(p1);
  EXPECT_EQ(p1->connection, 1u);
  int second = raw_connect((*server)->port());
  ASSERT_GE(second, 0);
  write_all(second, "PI,2,\n");
  auto p2 = (*server)->receive(kWait);
  ASSERT_TRUE(p2);
  EXPECT_EQ(p2->line, "PI,2,");
  EXPECT_EQ(p2->connection, 2u);
  char c = 0;
  EXPECT_EQ(::read(first, &c, 1), 0);  // the first peer was closed
  ASSERT_TRUE((*server)->send("AK,PI,2,\n"));
  EXPECT_EQ(read_line(second), "AK,PI,2,");
  ::close(first);
  ::close(second);
}

TEST(Tcp, TimeoutsReturnErrorsAndNeverHang) {
  auto server = TcpServer::create(ephemeral_server());
  ASSERT_TRUE(server);
  const auto t0 = std::chrono::steady_clock::now();
  auto r = (*server)->receive(Duration{100});
  ASSERT_FALSE(r);
  EXPECT_EQ(r.error().code, static_cast<int>(TransportError::kTimeout));
  auto w = (*server)->wait_connected(Duration{100});
  ASSERT_FALSE(w);
  EXPECT_EQ(w.error().code, static_cast<int>(TransportError::kTimeout));
  auto s = (*server)->send("PI,\n");
  ASSERT_FALSE(s);
  EXPECT_EQ(s.error().code, static_cast<int>(TransportError::kNotConnected));

  // a client towards a port where nobody listens keeps trying and times out cleanly
  const std::uint16_t port = (*server)->port();
  server.value().reset();
  auto client = TcpClient::create(client_for(port));
  ASSERT_TRUE(client);
  auto c = (*client)->wait_connected(Duration{300});
  ASSERT_FALSE(c);
  EXPECT_EQ(c.error().code, static_cast<int>(TransportError::kTimeout));
  EXPECT_LT(std::chrono::steady_clock::now() - t0, 3s);

  // close() wakes a blocked receiver with kClosed
  std::thread closer([&] {
    std::this_thread::sleep_for(50ms);
    (*client)->close();
  });
  auto closed = (*client)->receive(Duration{10000});
  closer.join();
  ASSERT_FALSE(closed);
  EXPECT_EQ(closed.error().code, static_cast<int>(TransportError::kClosed));
  EXPECT_EQ((*client)->state(), LinkState::kClosed);
  EXPECT_LT(std::chrono::steady_clock::now() - t0, 5s);
}

// A peer that connects but never says anything is dropped after idle_timeout; a peer that
// stops reading is dropped after write_timeout.
TEST(Tcp, IdleAndWriteTimeoutsDropADeadPeer) {
  TcpServerOptions o = ephemeral_server();
  o.link.idle_timeout = Duration{150};
  o.link.write_timeout = Duration{300};
  auto server = TcpServer::create(o);
  ASSERT_TRUE(server);
  int silent = raw_connect((*server)->port());
  ASSERT_GE(silent, 0);
  ASSERT_TRUE((*server)->wait_connected(kWait));
  const auto t0 = std::chrono::steady_clock::now();
  while ((*server)->connected() && std::chrono::steady_clock::now() - t0 < kWait) {
    std::this_thread::sleep_for(5ms);
  }
  EXPECT_FALSE((*server)->connected());
  EXPECT_GE(std::chrono::steady_clock::now() - t0, 100ms);
  EXPECT_EQ((*server)->counters().disconnects, 1u);
  EXPECT_GE((*server)->counters().errors, 1u);
  ::close(silent);

  // a reader that never reads, with a tiny receive buffer
  o.link.idle_timeout = Duration{0};
  auto server2 = TcpServer::create(o);
  ASSERT_TRUE(server2);
  int stuck = ::socket(AF_INET, SOCK_STREAM, 0);
  int small = 4096;
  ::setsockopt(stuck, SOL_SOCKET, SO_RCVBUF, &small, sizeof small);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_port = htons((*server2)->port());
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  ASSERT_EQ(::connect(stuck, reinterpret_cast<sockaddr*>(&a), sizeof a), 0);
  ASSERT_TRUE((*server2)->wait_connected(kWait));
  std::vector<std::uint8_t> big(8u << 20, 0x55);
  ASSERT_TRUE((*server2)->send_binary("IM," + std::to_string(big.size()) + ",", big));
  const auto t1 = std::chrono::steady_clock::now();
  while ((*server2)->connected() && std::chrono::steady_clock::now() - t1 < kWait) {
    std::this_thread::sleep_for(5ms);
  }
  EXPECT_FALSE((*server2)->connected());
  ::close(stuck);
}

TEST(Tcp, OverlongLinesAreCountedAndTheStreamResyncs) {
  auto server = TcpServer::create(ephemeral_server());
  ASSERT_TRUE(server);
  int fd = raw_connect((*server)->port());
  ASSERT_GE(fd, 0);
  write_all(fd, std::string(2000, 'J') + "\nPI,\n");
  auto bad = (*server)->receive(kWait);
  ASSERT_TRUE(bad);
  EXPECT_EQ(bad->kind, FrameKind::kOverlong);
  EXPECT_EQ(bad->line.size(), 511u);
  auto good = (*server)->receive(kWait);
  ASSERT_TRUE(good);
  EXPECT_EQ(good->line, "PI,");
  EXPECT_EQ((*server)->counters().overlong, 1u);
  ::close(fd);
}

TEST(Tcp, BadOptionsAreRefusedWithTheValue) {
  TcpClientOptions c;
  c.port = 0;
  auto r = TcpClient::create(c);
  ASSERT_FALSE(r);
  EXPECT_EQ(r.error().code, static_cast<int>(TransportError::kBadOption));
  EXPECT_NE(r.error().message.find("port 0"), std::string::npos);

  TcpServerOptions s;
  s.bind_address = "localhostx";
  auto r2 = TcpServer::create(s);
  ASSERT_FALSE(r2);
  EXPECT_NE(r2.error().message.find("localhostx"), std::string::npos);

  auto first = TcpServer::create(ephemeral_server());
  ASSERT_TRUE(first);
  TcpServerOptions same;
  same.port = (*first)->port();
  auto busy = TcpServer::create(same);
  ASSERT_FALSE(busy);
  EXPECT_EQ(busy.error().code, static_cast<int>(TransportError::kOpenFailed));
  EXPECT_NE(busy.error().message.find(std::to_string(same.port)), std::string::npos);
}

}  // namespace
}  // namespace scaratwin::transport

namespace scaratwin::transport {
namespace {

// Bytes leave in the order send() was called, even when the calls come from the io thread
// (inside a handler) and from another thread at the same time: Asio runs a handler posted
// from inside another handler only after that one returns, so ordering by posting alone
// lets a later send from another thread overtake an earlier one from the io thread (this
// reordered trajectory points on the serial link before it was fixed).
TEST(Tcp, SendOrderHoldsAcrossTheIoThreadAndOtherThreads) {
  auto io = IoThread::create();
  auto server = TcpServer::create(ephemeral_server(), io);
  ASSERT_TRUE(server);
  TcpServer* s = server->get();
  std::mutex order;  // decides the order of the numbers
  int next = 0;
  std::atomic<int> handler_sent{-1};
  std::atomic<int> main_sent{-1};
  constexpr int kRounds = 200;
  s->set_packet_handler([&](RxPacket&&) {
    int mine;
    {
      std::lock_guard<std::mutex> lock(order);
      mine = next++;
      (void)s->send(std::to_string(mine) + "\n");
    }
    handler_sent = mine;
    // stay inside the handler until the other thread has sent the following number.
    const auto until = std::chrono::steady_clock::now() + 2s;
    while (main_sent.load() < mine + 1 && std::chrono::steady_clock::now() < until) {
      std::this_thread::yield();
    }
  });
  const int fd = raw_connect(s->port());
  ASSERT_GE(fd, 0);
  ASSERT_TRUE(s->wait_connected(kWait));
  std::thread other([&] {
    for (int r = 0; r < kRounds; ++r) {
      const auto until = std::chrono::steady_clock::now() + 5s;
      while (handler_sent.load() < 2 * r && std::chrono::steady_clock::now() < until) {
        std::this_thread::yield();
      }
      std::lock_guard<std::mutex> lock(order);
      const int mine = next++;
      (void)s->send(std::to_string(mine) + "\n");
      main_sent = mine;
    }
  });
  for (int r = 0; r < kRounds; ++r) {
    write_all(fd, "GO,\n");
    for (int k = 0; k < 2; ++k) {
      const std::string line = read_line(fd);
      ASSERT_EQ(line, std::to_string(2 * r + k)) << "round " << r;
    }
  }
  other.join();
  ::close(fd);
}

}  // namespace
}  // namespace scaratwin::transport
