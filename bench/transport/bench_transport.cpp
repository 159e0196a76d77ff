// TCP loopback round-trip latency, p50/p99 over N packets (default 5000):
//   posix    blocking sockets, one echo thread: the floor of the machine
//   link     TcpClient -> TcpServer, echoed by the server's packet handler on its io thread,
//            awaited with receive(): what the hub pays per packet with the links
//   channel  SimChannel::request(JD) -> JA, a protocol peer (TcpServer + codec) answering on
//            its io thread: encode, send, decode, reply matching (func_data's path)
// Client and server each run their own io thread, as two processes would.
// Usage: bench_transport [round_trips]
#include <arpa/inet.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <thread>
#include <vector>

#include "scaratwin/protocol/codec.hpp"
#include "scaratwin/transport/channel.hpp"
#include "scaratwin/transport/io_thread.hpp"
#include "scaratwin/transport/tcp.hpp"

using namespace scaratwin;
using namespace scaratwin::transport;

namespace {

constexpr Duration kWait{5000};

struct Stats {
  double p50_us, p99_us, max_us, mean_us;
};

Stats stats(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  double sum = 0;
  for (double x : v) sum += x;
  auto at = [&](double q) {
    return v[static_cast<std::size_t>(q * static_cast<double>(v.size() - 1))];
  };
  return {at(0.5), at(0.99), v.back(), sum / static_cast<double>(v.size())};
}

double now_us() {
  return std::chrono::duration<double, std::micro>(
             std::chrono::steady_clock::now().time_since_epoch())
      .count();
}

const std::string kLine = "JD,17,5000123,120,12.5,-30.25,90,\n";

std::vector<double> bench_posix(int n) {
  int lfd = ::socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  ::bind(lfd, reinterpret_cast<sockaddr*>(&a), sizeof a);
  ::listen(lfd, 1);
  socklen_t len = sizeof a;
  ::getsockname(lfd, reinterpret_cast<sockaddr*>(&a), &len);
  std::thread echo([lfd] {
    int c = ::accept(lfd, nullptr, nullptr);
    int one = 1;
    ::setsockopt(c, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
    char buf[4096];
    for (;;) {
      ssize_t r = ::read(c, buf, sizeof buf);
      if (r <= 0) break;
      if (::write(c, buf, static_cast<std::size_t>(r)) != r) break;
    }
    ::close(c);
  });
  int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  ::connect(fd, reinterpret_cast<sockaddr*>(&a), sizeof a);
  int one = 1;
  ::setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
  std::vector<double> rtt;
  char buf[4096];
  for (int i = 0; i < n; ++i) {
    const double t0 = now_us();
    if (::write(fd, kLine.data(), kLine.size()) != static_cast<ssize_t>(kLine.size())) break;
    std::size_t got = 0;
    while (got < kLine.size()) {
      ssize_t r = ::read(fd, buf, sizeof buf);
      if (r <= 0) break;
      got += static_cast<std::size_t>(r);
    }
    rtt.push_back(now_us() - t0);
  }
  ::close(fd);
  echo.join();
  ::close(lfd);
  return rtt;
}

std::vector<double> bench_link(int n) {
  TcpServerOptions so;
  so.port = 0;
  auto server = TcpServer::create(so, IoThread::create("bench-server")).value().release();
  server->set_packet_handler([server](RxPacket&& p) { (void)server->send(p.line + "\n"); });
  TcpClientOptions co;
  co.port = server->port();
  auto client = std::move(TcpClient::create(co, IoThread::create("bench-client")).value());
  (void)client->wait_connected(kWait);
  (void)server->wait_connected(kWait);
  std::vector<double> rtt;
  for (int i = 0; i < n; ++i) {
    const double t0 = now_us();
    if (!client->send(kLine)) break;
    if (!client->receive(kWait)) break;
    rtt.push_back(now_us() - t0);
  }
  client.reset();
  delete server;
  return rtt;
}

std::vector<double> bench_channel(int n) {
  TcpServerOptions so;
  so.port = 0;
  auto server = TcpServer::create(so, IoThread::create("bench-sim")).value().release();
  // the simulator's side: decode with the codec, answer JD with JA
  auto decoder = std::make_shared<protocol::TcpToSimDecoder>();
  server->set_packet_handler([server, decoder](RxPacket&& p) {
    decoder->feed(p.line + "\n", [&](protocol::Decoded<protocol::TcpToSim>&& d) {
      if (auto* m = std::get_if<protocol::TcpToSim>(&d)) {
        if (auto* jd = std::get_if<protocol::JointData>(m)) {
          auto bytes = protocol::encode(protocol::TcpFromSim(
              protocol::JointApplied{jd->seq, static_cast<std::uint32_t>(steady_now_us())}));
          if (bytes) (void)server->send(std::move(*bytes));
        }
      }
    });
  });
  TcpClientOptions co;
  co.port = server->port();
  auto client = std::move(TcpClient::create(co, IoThread::create("bench-hub")).value());
  (void)client->wait_connected(kWait);
  (void)server->wait_connected(kWait);
  std::vector<double> rtt;
  {
    SimChannel channel(*client);
    protocol::JointData jd;
    jd.q = {0.1, 0.2, -0.3, 0.4};
    for (int i = 0; i < n; ++i) {
      jd.seq = static_cast<std::uint16_t>(i);
      jd.t_us = static_cast<std::uint32_t>(steady_now_us());
      const double t0 = now_us();
      if (!channel.request(jd, kWait)) break;
      rtt.push_back(now_us() - t0);
    }
  }
  client.reset();
  delete server;
  return rtt;
}

}  // namespace

int main(int argc, char** argv) {
  const int n = argc > 1 ? std::max(100, std::atoi(argv[1])) : 5000;
  std::printf("TCP loopback round trip, %d packets each (us)\n\n", n);
  std::printf("| case | packets | p50 | p99 | max | mean |\n|---|---|---|---|---|---|\n");
  auto row = [&](const char* name, const std::vector<double>& v) {
    if (v.size() < 10) {
      std::printf("| %s | failed after %zu |  |  |  |  |\n", name, v.size());
      return;
    }
    // drop the first 1% (connection warm-up)
    std::vector<double> w(v.begin() + static_cast<long>(v.size() / 100), v.end());
    Stats s = stats(w);
    std::printf("| %s | %zu | %.1f | %.1f | %.1f | %.1f |\n", name, w.size(), s.p50_us, s.p99_us,
                s.max_us, s.mean_us);
  };
  row("posix blocking sockets (floor)", bench_posix(n));
  row("scaratwin link (send + receive)", bench_link(n));
  row("scaratwin channel (JD -> JA request)", bench_channel(n));
  return 0;
}
