#include "scaratwin/hub/flasher.hpp"

#include <fcntl.h>
#include <poll.h>
#include <termios.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <sstream>

#include <fmt/format.h>

#include "scaratwin/hub/process.hpp"

namespace scaratwin {
namespace {

using Clock = std::chrono::steady_clock;

std::filesystem::path find_program(const std::string& name) {
  if (name.find('/') != std::string::npos) return name;
  const char* path = std::getenv("PATH");
  std::istringstream dirs(path != nullptr ? path : "/usr/bin:/bin");
  std::string dir;
  while (std::getline(dirs, dir, ':')) {
    std::filesystem::path p = std::filesystem::path(dir.empty() ? "." : dir) / name;
    if (::access(p.c_str(), X_OK) == 0) return p;
  }
  return {};
}

std::vector<std::string> split_fields(const std::string& line) {
  std::vector<std::string> out;
  std::string field;
  for (char c : line) {
    if (c == '=') {
      out.push_back(field);
      field.clear();
    } else {
      field += c;
    }
  }
  return out;
}

// The data bytes of an Intel HEX text, in file order (avrdude checks the records themselves).
std::string hex_data(const std::string& text) {
  std::string bytes;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);) {
    if (line.size() < 11 || line[0] != ':' || line.compare(7, 2, "00") != 0) continue;
    const std::size_t count = std::stoul(line.substr(1, 2), nullptr, 16);
    for (std::size_t i = 0; i < count && 9 + 2 * i + 1 < line.size(); ++i) {
      bytes += static_cast<char>(std::stoul(line.substr(9 + 2 * i, 2), nullptr, 16));
    }
  }
  return bytes;
}

}  // namespace

std::string firmware_device_in_hex(const std::string& hex_text) {
  // our images carry their device name ("scara-uno", "scara-mega") for the hello
  std::string data;
  try {
    data = hex_data(hex_text);
  } catch (const std::exception&) {
    return {};  // not hex digits: avrdude says what is wrong
  }
  const std::size_t at = data.find("scara-");
  if (at == std::string::npos) return {};
  std::size_t end = at + 6;
  while (end < data.size() && data[end] >= 'a' && data[end] <= 'z') ++end;
  if (end == at + 6 || end >= data.size() || data[end] != '\0') return {};
  return data.substr(at, end - at);
}

Result<std::vector<std::string>> board_hello(const std::string& port, const std::string& hash,
                                             double timeout_s) {
  const int fd = ::open(port.c_str(), O_RDWR | O_NOCTTY | O_NONBLOCK);
  if (fd < 0) {
    return Error{HubError::kFailed,
                 fmt::format("cannot open the serial port {}: {}", port, std::strerror(errno))};
  }
  termios tio{};
  if (::tcgetattr(fd, &tio) != 0) {
    ::close(fd);
    return Error{HubError::kFailed, fmt::format("{} is not a serial port", port)};
  }
  cfmakeraw(&tio);
  cfsetispeed(&tio, B115200);
  cfsetospeed(&tio, B115200);
  ::tcsetattr(fd, TCSANOW, &tio);
  ::tcflush(fd, TCIFLUSH);
  const std::string hello = hash.empty() ? "HI=1=\n" : "HI=1=" + hash + "=\n";
  std::vector<std::string> unsolicited;  // the firmware's own hello after a reset
  const auto end = Clock::now() + std::chrono::duration_cast<Clock::duration>(
                                      std::chrono::duration<double>(timeout_s));
  auto next_hello = Clock::now();
  auto deadline = end;
  std::string buf;
  while (Clock::now() < deadline) {
    if (Clock::now() >= next_hello) {
      // a board in its bootloader takes the first bytes for STK500 and leaves for the firmware
      if (::write(fd, hello.data(), hello.size()) < 0 && errno != EAGAIN) break;
      next_hello = Clock::now() + std::chrono::milliseconds(500);
    }
    pollfd p{fd, POLLIN, 0};
    ::poll(&p, 1, 50);
    char chunk[256];
    const ssize_t n = ::read(fd, chunk, sizeof chunk);
    if (n > 0) buf.append(chunk, static_cast<std::size_t>(n));
    for (std::size_t nl; (nl = buf.find('\n')) != std::string::npos;) {
      std::string line = buf.substr(0, nl);
      buf.erase(0, nl + 1);
      if (!line.empty() && line.back() == '\r') line.pop_back();
      if (line.rfind("HI=", 0) == 0) {
        auto fields = split_fields(line);
        fields.erase(fields.begin());  // the code
        // a hello without the description is the firmware's own after its reset: ask once
        // more for the answer to ours (an older firmware never says it: that one then)
        if (!hash.empty() && fields.size() < 4 && unsolicited.empty()) {
          unsolicited = fields;
          next_hello = Clock::now();
          deadline = std::min(end, Clock::now() + std::chrono::seconds(2));
          continue;
        }
        ::close(fd);
        return fields;
      }
    }
  }
  ::close(fd);
  if (!unsolicited.empty()) return unsolicited;
  return Error{HubError::kNotReady,
               fmt::format("the board on {} did not say hello within {:.0f} s (no firmware, or "
                           "not a scaratwin board)",
                           port, timeout_s)};
}

Result<FlashResult> flash_board(const FlashOptions& o,
                                const std::function<void(const std::string&)>& progress) {
  const std::filesystem::path avrdude = find_program(o.avrdude);
  if (avrdude.empty()) {
    return Error{HubError::kStartFailed,
                 fmt::format("'{}' is not installed (Debian: apt-get install avrdude)", o.avrdude)};
  }
  std::error_code ec;
  if (!std::filesystem::is_regular_file(o.hex, ec)) {
    return Error{HubError::kFailed, fmt::format("no firmware image at {}", o.hex.string())};
  }
  {
    std::ifstream f(o.hex);
    std::stringstream text;
    text << f.rdbuf();
    const std::string device = firmware_device_in_hex(text.str());
    if (!device.empty() && device != o.device) {
      return Error{HubError::kFailed,
                   fmt::format("{} is the firmware of another board ({}); this board takes {}'s "
                               "(nothing was written)",
                               o.hex.string(), device, o.device)};
    }
  }
  // -U ...:w: verifies by reading back (avrdude's default); the file's format given (i)
  const std::vector<std::string> args{"-c", o.programmer,
                                      "-p", o.part,
                                      "-P", o.port,
                                      "-b", std::to_string(o.baud),
                                      "-U", "flash:w:" + o.hex.string() + ":i"};
  auto child = ChildProcess::start(avrdude, args);
  if (!child) return child.error();
  const int status = (*child)->wait_exit(
      std::chrono::milliseconds(static_cast<long>(o.avrdude_timeout_s * 1000.0)));
  FlashResult result;
  std::istringstream out((*child)->output_tail(100000));
  for (std::string line; std::getline(out, line);) {
    line.erase(0, line.find_first_not_of(' '));  // output_tail() indents
    if (line.empty()) continue;
    result.avrdude_output.push_back(line);
    if (progress) progress(line);
    long n = 0;
    if (std::sscanf(line.c_str(), "avrdude: %ld bytes of flash verified", &n) == 1) {
      result.bytes_verified = n;
    }
  }
  if (status != 0) {
    // avrdude's own reasons, without its complaint that a pty has no modem lines
    std::string why;
    for (const std::string& l : result.avrdude_output) {
      const bool reason =
          (l.rfind("avrdude error", 0) == 0 || l.rfind("avrdude OS error", 0) == 0 ||
           l.find("not in sync") != std::string::npos) &&
          l.find("ioctl(") == std::string::npos;
      if (reason) why += (why.empty() ? "" : "; ") + l;
    }
    if (why.empty() && !result.avrdude_output.empty()) why = result.avrdude_output.back();
    // what the board runs now: the old firmware where nothing was written
    auto now = board_hello(o.port, {}, 4.0);
    std::string after;
    if (now && now->size() >= 3) {
      after = fmt::format("the board still runs {} {}", (*now)[1], (*now)[2]);
    } else if (!now && now.error().code == static_cast<int>(HubError::kNotReady)) {
      after = "the board does not answer a hello now (no firmware runs: flash it again)";
    } else {
      after = now ? "the board answers an unknown hello" : now.error().message;
    }
    return Error{HubError::kFailed,
                 fmt::format("avrdude refused to flash {} ({}): {}; {}", o.port,
                             status < 0 ? fmt::format("killed by signal {}", -status)
                                        : fmt::format("exit {}", status),
                             why, after)};
  }
  auto hello = board_hello(o.port, o.description_hash, o.hello_timeout_s);
  if (!hello) {
    return Error{hello.error().code,
                 "avrdude wrote and verified the firmware, but " + hello.error().message};
  }
  const auto& f = *hello;
  if (f.size() >= 3) {
    result.device = f[1];
    result.fw_version = f[2];
  }
  if (f.size() >= 4) result.description = f[3];
  return result;
}

}  // namespace scaratwin
