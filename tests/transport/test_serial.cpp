// Serial links over pseudo-terminals (openpty): the test holds the master side and plays the
// device; the link opens the slave side through a symlink, as udev's /dev/serial/by-id links.
#include "scaratwin/transport/serial.hpp"

#include <fcntl.h>
#include <gtest/gtest.h>
#include <poll.h>
#include <pty.h>
#include <termios.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <thread>

#include "eventually.hpp"

namespace scaratwin::transport {
namespace {

using namespace std::chrono_literals;
namespace fs = std::filesystem;

constexpr Duration kWait{5000};

// One pty whose master side the test drives.
struct Pty {
  int master = -1;
  int slave = -1;
  std::string slave_path;

  Pty() {
    termios raw{};
    ::cfmakeraw(&raw);
    char name[128] = {};
    if (::openpty(&master, &slave, name, &raw, nullptr) != 0) return;
    slave_path = name;
  }
  ~Pty() { close_all(); }
  // Closing both ends makes the device vanish: reads on the link's side fail with EIO.
  void close_all() {
    if (slave >= 0) ::close(slave);
    if (master >= 0) ::close(master);
    slave = master = -1;
  }
  bool ok() const { return master >= 0; }

  void write(std::string_view bytes) const {
    while (!bytes.empty()) {
      ssize_t n = ::write(master, bytes.data(), bytes.size());
      if (n <= 0) return;
      bytes.remove_prefix(static_cast<std::size_t>(n));
    }
  }
  // Reads one line (without '\n') within `timeout`, or "<timeout>".
  std::string read_line(std::chrono::milliseconds timeout = 5000ms) const {
    std::string line;
    const auto end = std::chrono::steady_clock::now() + timeout;
    while (std::chrono::steady_clock::now() < end) {
      pollfd p{master, POLLIN, 0};
      if (::poll(&p, 1, 20) <= 0) continue;
      char c = 0;
      if (::read(master, &c, 1) != 1) continue;
      if (c == '\n') return line;
      line.push_back(c);
    }
    return "<timeout>";
  }
};

struct TempDir {
  fs::path path;
  TempDir() {
    char tmpl[] = "/tmp/scaratwin-serial-XXXXXX";
    path = ::mkdtemp(tmpl);
  }
  ~TempDir() {
    std::error_code ec;
    fs::remove_all(path, ec);
  }
};

SerialOptions options_for(const std::string& device) {
  SerialOptions o;
  o.device = device;
  o.link.reconnect_min = Duration{20};
  o.link.reconnect_max = Duration{100};
  return o;
}

TEST(Serial, PtyRoundTrip) {
  Pty pty;
  ASSERT_TRUE(pty.ok());
  auto link = SerialLink::create(options_for(pty.slave_path));
  ASSERT_TRUE(link) << link.error().message;
  SerialLink& l = **link;
  ASSERT_TRUE(l.wait_connected(kWait)) << l.name();

  const std::string load = "TB=3=\nTP=0=500=24600=-1200=2000=4500=\n";
  ASSERT_TRUE(l.send(load));
  EXPECT_EQ(pty.read_line(), "TB=3=");
  EXPECT_EQ(pty.read_line(), "TP=0=500=24600=-1200=2000=4500=");
  // real-time byte: no newline, counted as bytes but not as a packet
  ASSERT_TRUE(l.send("!"));
  ASSERT_TRUE(l.send("PI=\n"));
  EXPECT_EQ(pty.read_line(), "!PI=");

  // the device answers one byte at a time, with a CR LF
  const std::string reply = "AK=TB=8=\r\nST=7=123456=100=-200=300=4500=0=5=8=\n";
  for (char c : reply) {
    pty.write(std::string_view(&c, 1));
    std::this_thread::sleep_for(100us);
  }
  auto a = l.receive(kWait);
  ASSERT_TRUE(a) << a.error().message;
  EXPECT_EQ(a->line, "AK=TB=8=");
  auto b = l.receive(kWait);
  ASSERT_TRUE(b);
  EXPECT_EQ(b->line, "ST=7=123456=100=-200=300=4500=0=5=8=");
  EXPECT_GE(b->steady_us, a->steady_us);

  EXPECT_TRUE(eventually([&] { return l.counters().packets_out == 3u; }));
  auto c = l.counters();
  EXPECT_EQ(c.packets_out, 3u);
  EXPECT_EQ(c.packets_in, 2u);
  EXPECT_EQ(c.bytes_out, load.size() + 1u + 4u);
  EXPECT_EQ(c.errors, 0u);
}

TEST(Serial, PtyIsRawEightBitClean) {
  Pty pty;
  ASSERT_TRUE(pty.ok());
  auto link = SerialLink::create(options_for(pty.slave_path));
  ASSERT_TRUE(link);
  ASSERT_TRUE((*link)->wait_connected(kWait));
  // no CR/LF translation, no echo, no signals from ^C, no XON/XOFF, 8-bit
  std::string bytes = "A\r\x03\x11\x13\x7f\xff";
  bytes += '\n';
  pty.write(bytes);
  auto p = (*link)->receive(kWait);
  ASSERT_TRUE(p);
  EXPECT_EQ(p->line, bytes.substr(0, bytes.size() - 1));
  termios tio{};
  ASSERT_EQ(::tcgetattr(pty.slave, &tio), 0);
  EXPECT_EQ(tio.c_lflag & (ICANON | ECHO | ISIG), 0u);
  EXPECT_EQ(tio.c_cflag & CSIZE, static_cast<tcflag_t>(CS8));
  EXPECT_EQ(tio.c_cflag & (PARENB | CSTOPB | CRTSCTS), 0u);
  EXPECT_EQ(tio.c_iflag & (IXON | IXOFF | ICRNL), 0u);
  EXPECT_EQ(::cfgetospeed(&tio), static_cast<speed_t>(B115200));
}

TEST(Serial, ReopensTheDeviceWhenItComesBack) {
  TempDir dir;
  const fs::path device = dir.path / "ttySCARA";
  auto first = std::make_unique<Pty>();
  ASSERT_TRUE(first->ok());
  fs::create_symlink(first->slave_path, device);
  auto link = SerialLink::create(options_for(device.string()));
  ASSERT_TRUE(link);
  SerialLink& l = **link;
  ASSERT_TRUE(l.wait_connected(kWait));
  first->write("HI=1=scara-uno=0.1.0=\n");
  auto hello = l.receive(kWait);
  ASSERT_TRUE(hello);
  EXPECT_EQ(hello->connection, 1u);

  // unplug: the device vanishes, mid-line
  first->write("ST=1=2=");
  std::this_thread::sleep_for(20ms);
  first.reset();
  fs::remove(device);
  const auto t0 = std::chrono::steady_clock::now();
  while (l.connected() && std::chrono::steady_clock::now() - t0 < kWait) {
    std::this_thread::sleep_for(2ms);
  }
  EXPECT_FALSE(l.connected());
  EXPECT_FALSE(l.send("PI=\n"));
  std::this_thread::sleep_for(100ms);  // failed reopen attempts meanwhile

  // plug back in (a new pty behind the same path)
  Pty second;
  ASSERT_TRUE(second.ok());
  fs::create_symlink(second.slave_path, device);
  ASSERT_TRUE(l.wait_connected(kWait));
  second.write("HI=1=scara-uno=0.1.0=\n");
  auto again = l.receive(kWait);
  ASSERT_TRUE(again);
  EXPECT_EQ(again->line, "HI=1=scara-uno=0.1.0=");  // the cut "ST=1=2=" was dropped
  EXPECT_EQ(again->connection, 2u);
  ASSERT_TRUE(l.send("QS=\n"));
  EXPECT_EQ(second.read_line(), "QS=");
  auto c = l.counters();
  EXPECT_EQ(c.connects, 2u);
  EXPECT_EQ(c.reconnects, 1u);
  EXPECT_EQ(c.disconnects, 1u);
  EXPECT_GE(c.errors, 1u);  // the I/O error and the cut packet
}

TEST(Serial, OverlongLineFollowsTheSerialLimit) {
  Pty pty;
  ASSERT_TRUE(pty.ok());
  auto link = SerialLink::create(options_for(pty.slave_path));
  ASSERT_TRUE(link);
  ASSERT_TRUE((*link)->wait_connected(kWait));
  pty.write(std::string(96, '1') + "\n" + std::string(95, '2') + "\n");
  auto a = (*link)->receive(kWait);
  ASSERT_TRUE(a);
  EXPECT_EQ(a->kind, FrameKind::kOverlong);
  auto b = (*link)->receive(kWait);
  ASSERT_TRUE(b);
  EXPECT_EQ(b->kind, FrameKind::kLine);
  EXPECT_EQ(b->line, std::string(95, '2'));
}

TEST(Serial, MissingDeviceTimesOutAndBadOptionsAreRefused) {
  auto link = SerialLink::create(options_for("/dev/scaratwin-no-such-device"));
  ASSERT_TRUE(link);
  auto w = (*link)->wait_connected(Duration{200});
  ASSERT_FALSE(w);
  EXPECT_EQ(w.error().code, static_cast<int>(TransportError::kTimeout));
  auto r = (*link)->receive(Duration{50});
  ASSERT_FALSE(r);
  EXPECT_EQ(r.error().code, static_cast<int>(TransportError::kTimeout));

  SerialOptions o = options_for("/dev/ttyACM0");
  o.baud = 12345;
  auto bad = SerialLink::create(o);
  ASSERT_FALSE(bad);
  EXPECT_EQ(bad.error().code, static_cast<int>(TransportError::kBadOption));
  EXPECT_NE(bad.error().message.find("12345"), std::string::npos);
  auto empty = SerialLink::create(options_for(""));
  ASSERT_FALSE(empty);
}

}  // namespace
}  // namespace scaratwin::transport
