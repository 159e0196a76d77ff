// The emulated Uno at its USB port, as a real board is (issue: a real Arduino on the desk):
// opening the port resets the MCU (un-homed, EEPROM kept) unless its auto-reset is cut; a new
// board runs only its bootloader (optiboot) until `scaratwin flash` writes the firmware with
// Debian's avrdude; the flash persists across restarts; a corrupt, out-of-range or
// other-board image is refused and leaves the old firmware running. Judged by the emulator's
// truth channel (its resets, STEP pulses) and by what the board answers on its port.
#include <fcntl.h>
#include <poll.h>
#include <termios.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <optional>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include "hub_test_support.hpp"
#include "scaratwin/config/robot_config.hpp"
#include "scaratwin/hub/flasher.hpp"
#include "scaratwin/hub/process.hpp"

namespace scaratwin {
namespace {

namespace fs = std::filesystem;
using namespace std::chrono_literals;
using test::Outcome;
using test::truth;

const fs::path kBin = SCARATWIN_BIN_DIR;
const fs::path kHex = SCARATWIN_FIRMWARE_HEX;

// A host's serial port on the board: opened raw at 115200 with its input flushed, as the hub
// opens it; closed when it goes.
class Port {
 public:
  explicit Port(const fs::path& path) {
    fd_ = ::open(path.c_str(), O_RDWR | O_NOCTTY | O_NONBLOCK);
    if (fd_ < 0) return;
    termios tio{};
    ::tcgetattr(fd_, &tio);
    cfmakeraw(&tio);
    cfsetspeed(&tio, B115200);
    ::tcsetattr(fd_, TCSANOW, &tio);
    ::tcflush(fd_, TCIFLUSH);
  }
  ~Port() {
    if (fd_ >= 0) ::close(fd_);
  }
  Port(const Port&) = delete;
  Port& operator=(const Port&) = delete;
  bool ok() const { return fd_ >= 0; }
  void send(const std::string& s) { (void)!::write(fd_, s.data(), s.size()); }
  // The next line starting with `prefix` (others skipped), or nullopt after `timeout`.
  std::optional<std::string> wait_for(const std::string& prefix,
                                      std::chrono::milliseconds timeout = 10s) {
    const auto end = std::chrono::steady_clock::now() + timeout;
    while (std::chrono::steady_clock::now() < end) {
      for (std::size_t nl; (nl = buf_.find('\n')) != std::string::npos;) {
        std::string line = buf_.substr(0, nl);
        buf_.erase(0, nl + 1);
        if (line.rfind(prefix, 0) == 0) return line;
      }
      pollfd p{fd_, POLLIN, 0};
      ::poll(&p, 1, 20);
      char chunk[512];
      const ssize_t n = ::read(fd_, chunk, sizeof chunk);
      if (n > 0) buf_.append(chunk, static_cast<std::size_t>(n));
    }
    return std::nullopt;
  }
  // Sends a hello every 500 ms until the firmware answers (a board spends about 1.5 s in its
  // bootloader after the open reset it); the hello line, or nullopt.
  std::optional<std::string> hello(std::chrono::milliseconds timeout = 10s) {
    const auto end = std::chrono::steady_clock::now() + timeout;
    while (std::chrono::steady_clock::now() < end) {
      send("HI=1=\n");
      if (auto l = wait_for("HI=", 500ms)) return l;
    }
    return std::nullopt;
  }
  // The flags of a state report (QS), or -1.
  long flags() {
    send("QS=\n");
    auto st = wait_for("ST=", 5s);
    if (!st) return -1;
    // ST=seq=t_us=z=j2=j3=wrist=grip=flags=queue_free=
    std::vector<std::string> f;
    std::string field;
    for (char c : st->substr(3)) {
      if (c == '=') {
        f.push_back(field);
        field.clear();
      } else {
        field += c;
      }
    }
    return f.size() >= 8 ? std::stol(f[7]) : -1;
  }

 private:
  int fd_ = -1;
  std::string buf_;
};

constexpr long kHomed = 1;  // ST flags (docs/protocol.md section 8)

struct Board {
  std::unique_ptr<ChildProcess> process;
  fs::path pty;
  int side_port = 0;
};

void start_board(const fs::path& dir, const std::vector<std::string>& extra, Board* b,
                 bool auto_reset = true) {
  b->pty = dir / "robot.pty";
  std::vector<std::string> args{"--plant", "ideal", "--pty-link", b->pty.string(),
                                auto_reset ? "--auto-reset" : "--no-auto-reset"};
  args.insert(args.end(), extra.begin(), extra.end());
  auto robot = ChildProcess::start(kBin / "scaratwin-robot", args, dir / "robot.log");
  ASSERT_TRUE(robot) << robot.error().message;
  b->process = std::move(*robot);
  auto side = b->process->wait_for_line("side channel: ", 60s);
  ASSERT_TRUE(side) << side.error().message;
  b->side_port = std::stoi(side->substr(side->rfind(':') + 1));
}

int truth_int(int side_port, const std::string& key) {
  const auto t = truth(side_port);
  const auto it = t.find(key);
  return it == t.end() ? -1 : std::stoi(it->second);
}

// Opening the port is a reset: the firmware comes back un-homed and refuses a trajectory with
// not_homed (ER 7), its EEPROM settings kept; closing and opening resets it again. The
// emulator's truth counts the external resets: one per open, none while the port stays open.
TEST(UnoBoard, OpeningThePortResetsItUnhomedWithItsEepromKept) {
  const fs::path dir = test::fresh_dir("board-reset");
  Board b;
  ASSERT_NO_FATAL_FAILURE(start_board(dir, {"--eeprom", (dir / "eeprom.bin").string()}, &b));
  EXPECT_EQ(truth_int(b.side_port, "resets"), 0) << "powered up, no host yet";
  {
    Port p(b.pty);
    ASSERT_TRUE(p.ok());
    ASSERT_TRUE(p.hello()) << "no hello after the open's reset";
    EXPECT_EQ(truth_int(b.side_port, "resets"), 1);
    p.send("HM=\n");
    ASSERT_TRUE(p.wait_for("EV=1=", 60s)) << "homing";
    EXPECT_EQ(p.flags() & kHomed, kHomed);
    p.send("CF=7=2500=\n");
    EXPECT_EQ(p.wait_for("AK=CF=").value_or(""), "AK=CF=2500=");
    EXPECT_EQ(truth_int(b.side_port, "resets"), 1) << "no reset while the port stays open";
  }
  {
    Port p(b.pty);
    ASSERT_TRUE(p.ok());
    ASSERT_TRUE(p.hello());
    EXPECT_EQ(truth_int(b.side_port, "resets"), 2) << "the second open reset the board";
    const long flags = p.flags();
    ASSERT_GE(flags, 0);
    EXPECT_EQ(flags & kHomed, 0) << "un-homed after the reset";
    p.send("TB=2=\n");
    EXPECT_EQ(p.wait_for("ER=").value_or(""), "ER=7=") << "a trajectory needs homing";
    p.send("CF=7=\n");
    EXPECT_EQ(p.wait_for("AK=CF=").value_or(""), "AK=CF=2500=") << "the EEPROM kept its setting";
  }
  // an open closed at once still resets the board, as DTR does
  { Port quick(b.pty); }
  { Port quick(b.pty); }
  std::this_thread::sleep_for(100ms);
  EXPECT_EQ(truth_int(b.side_port, "resets"), 4);
  b.process->stop();
  fs::remove_all(dir);
}

// --no-auto-reset: the board with its auto-reset cut keeps running across opens (homed stays
// homed); its truth counts no reset.
TEST(UnoBoard, WithItsAutoResetCutOpeningThePortResetsNothing) {
  const fs::path dir = test::fresh_dir("board-no-reset");
  Board b;
  ASSERT_NO_FATAL_FAILURE(start_board(dir, {}, &b, false));
  {
    Port p(b.pty);
    ASSERT_TRUE(p.hello());
    p.send("HM=\n");
    ASSERT_TRUE(p.wait_for("EV=1=", 60s)) << "homing";
  }
  {
    Port p(b.pty);
    ASSERT_TRUE(p.hello());
    EXPECT_EQ(p.flags() & kHomed, kHomed) << "still homed";
  }
  EXPECT_EQ(truth_int(b.side_port, "resets"), 0);
  b.process->stop();
  fs::remove_all(dir);
}

// The bytes avrdude writes: the image's text and data, from the ELF beside the HEX (avr-size,
// an oracle independent of avrdude and of the emulator).
long image_bytes() {
  fs::path elf = kHex;
  elf.replace_extension(".elf");
  const Outcome o = test::run_program("/usr/bin/avr-size", {elf.string()});
  long text = -1, data = -1;
  std::istringstream in(o.output);
  std::string header;
  std::getline(in, header);
  in >> text >> data;
  return text >= 0 && data >= 0 ? text + data : -1;
}

// A new board runs only its bootloader; `scaratwin flash` writes the packaged firmware through
// it with avrdude, verifies it, and the board then runs it (a hello, a homing judged by the
// truth's STEP pulses); the flash survives a restart; bad images are refused and the old
// firmware stays.
TEST(UnoBoard, ANewBoardIsFlashedWithAvrdudeThroughItsBootloader) {
  const fs::path dir = test::fresh_dir("board-flash");
  const fs::path flash = dir / "flash.bin";
  auto model = load_robot_config(SCARATWIN_CONFIG_FILE);
  ASSERT_TRUE(model) << model.error().message;
  const std::string hash = description_hash(*model);
  {
    Board b;
    ASSERT_NO_FATAL_FAILURE(
        start_board(dir, {"--firmware", "none", "--flash", flash.string()}, &b));
    auto blank = board_hello(b.pty.string(), {}, 3.0);
    EXPECT_FALSE(blank) << "a new board has no firmware to say hello";
    const Outcome none =
        test::run_program(kBin / "scaratwin", {"flash", "--serial", (dir / "none").string()});
    EXPECT_EQ(none.status, 2) << none.output;
    EXPECT_NE(none.output.find(fmt::format("--serial {}: no such port", (dir / "none").string())),
              std::string::npos)
        << none.output;
    const Outcome o =
        test::run_program(kBin / "scaratwin", {"flash", "--serial", b.pty.string()}, 180s);
    ASSERT_EQ(o.status, 0) << o.output;
    const long bytes = image_bytes();
    ASSERT_GT(bytes, 1000);
    EXPECT_NE(o.output.find(fmt::format("flashed and verified: {} bytes", bytes)),
              std::string::npos)
        << o.output;
    EXPECT_NE(o.output.find(fmt::format("the board runs: scara-uno 0.1.0, description {}", hash)),
              std::string::npos)
        << o.output;
    // drive the flashed firmware: it homes, moving the motors
    {
      Port p(b.pty);
      ASSERT_TRUE(p.hello());
      p.send("HM=\n");
      ASSERT_TRUE(p.wait_for("EV=1=", 60s)) << "the flashed firmware homes";
    }
    const auto t = truth(b.side_port);
    ASSERT_FALSE(t.empty());
    EXPECT_GT(std::stol(t.at("steps_z")), 0) << "homing moved Z";
    EXPECT_GT(std::stol(t.at("steps_j2")), 0) << "homing moved J2";
    // a checksum error, an address beyond the 32 KiB flash, the Mega's image: refused, and
    // the board still runs the firmware flashed above
    std::ifstream in(kHex);
    std::vector<std::string> lines;
    for (std::string l; std::getline(in, l);) lines.push_back(l);
    ASSERT_GT(lines.size(), 10u);
    lines[4][9] = lines[4][9] == 'F' ? 'E' : 'F';  // a data digit: the checksum no longer adds up
    {
      std::ofstream out(dir / "corrupt.hex");
      for (const auto& l : lines) out << l << "\n";
    }
    std::ofstream(dir / "big.hex")
        << ":020000040001F9\n:10000000FFFFFFFFFFFFFFFFFFFFFFFFFFFFFFFF00\n"
           ":00000001FF\n";
    fs::path mega = kHex.parent_path().parent_path() / "mega" / "scaratwin-fw-mega.hex";
    struct Bad {
      fs::path hex;
      std::string says;
    };
    const Bad bad[] = {
        {dir / "corrupt.hex", "avrdude error: checksum mismatch at line 5"},
        {dir / "big.hex", "avrdude error: address 0x10010 out of range at line 2"},
        {mega,
         "is the firmware of another board (scara-mega); this board takes scara-uno's "
         "(nothing was written)"},
    };
    for (const Bad& x : bad) {
      const Outcome r = test::run_program(
          kBin / "scaratwin", {"flash", "--serial", b.pty.string(), "--hex", x.hex.string()}, 180s);
      EXPECT_EQ(r.status, 1) << r.output;
      EXPECT_NE(r.output.find(x.says), std::string::npos) << x.hex << "\n" << r.output;
      auto still = board_hello(b.pty.string(), hash, 10.0);
      ASSERT_TRUE(still) << x.hex << ": " << still.error().message;
      ASSERT_GE(still->size(), 4u);
      EXPECT_EQ((*still)[1], "scara-uno") << x.hex;
      EXPECT_EQ((*still)[3], hash) << x.hex;
    }
    b.process->stop();
  }
  // a restart: the board keeps what was flashed
  {
    Board b;
    ASSERT_NO_FATAL_FAILURE(start_board(dir, {"--flash", flash.string()}, &b));
    auto hello = board_hello(b.pty.string(), hash, 10.0);
    ASSERT_TRUE(hello) << hello.error().message;
    ASSERT_GE(hello->size(), 4u);
    EXPECT_EQ((*hello)[1], "scara-uno");
    EXPECT_EQ((*hello)[3], hash);
    b.process->stop();
  }
  fs::remove_all(dir);
}

}  // namespace
}  // namespace scaratwin
